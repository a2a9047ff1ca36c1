"""The mutators' one random choice: an item drawn with probability proportional to its weight."""
from __future__ import annotations

import random


def weighted(rnd: random.Random, items):
    """One item of [(item, weight), ...], drawn with rnd (one rnd.random() per call)."""
    total = sum(w for _, w in items)
    x = rnd.random() * total
    for item, w in items:
        x -= w
        if x <= 0:
            return item
    return items[-1][0]
