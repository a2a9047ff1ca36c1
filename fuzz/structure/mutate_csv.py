"""Structure-level mutations of BRDF tables (CSV, docs/user_data.md) for
fuzz/structure/fuzz_user_data.py: columns, rows, cells, encodings, line ends and sizes.

mutate(path, rnd, count) rewrites the CSV at `path` and returns (path, [(description, variant,
operator)]); "variant" marks an equivalent table a reader may reasonably accept (columns
reordered, CRLF line ends, blank lines, ...).

The table is handled as (comment lines, header cells, rows of cells); a few operators work on the
final bytes (BOM, NUL, CR, UTF-16, huge lines) and are applied when the table is written.
"""

from __future__ import annotations

import random
from weighted import weighted


class Table:
    def __init__(self, text):
        lines = text.splitlines()
        self.comments = [l for l in lines if l.startswith("#")]
        data = [l for l in lines if l and not l.startswith("#")]
        self.header = data[0].split(",")
        self.rows = [l.split(",") for l in data[1:]]
        self.byte_ops = []  # functions bytes -> bytes, applied in order by render()
        self.newline = "\n"
        self.separator = ","
        self.raw_lines = None  # set by operators that need full control of the lines
        self.repeat_rows = 0  # > 0: the data rows repeated up to this many (huge_rows)
        self.bad_last_row = False

    def col(self, name):
        return self.header.index(name) if name in self.header else None

    def render(self):
        if self.raw_lines is not None:
            lines = self.raw_lines
        else:
            rows = [self.separator.join(r) for r in self.rows]
            if self.repeat_rows and rows:
                rows = (rows * (self.repeat_rows // len(rows) + 1))[: self.repeat_rows]
                if self.bad_last_row:
                    rows[-1] = "bad" + rows[-1][rows[-1].find(self.separator):]
            lines = self.comments + [self.separator.join(self.header)] + rows
        text = self.newline.join(lines) + self.newline
        data = text.encode("utf-8", "surrogatepass")
        for op in self.byte_ops:
            data = op(data)
        return data


BAD_NUMBERS = ["NaN", "nan", "inf", "-inf", "Infinity", "1e308", "1e309", "-1e309", "1e-320",
               "4.9e-324", "", " ", "1,5", "0x10", "+1", "1e", ".", "-", "--1", "1..2", "١٢",
               "３０", "30°", "\"30\"", "'30'", "30 deg", "1_000", "0b1", "1e+", "nan(0x1)",
               "9" * 400, "-0", "1e-400", "30\u00a0", "\u221230"]
ANGLE_VALUES = ["90", "89.99999999", "-0.0", "-1", "180", "1e308", "-90", "360", "720", "1e-320"]
PHI_VALUES = ["1e308", "-1e308", "720", "-360", "1e16", "3.4e38"]
WAVELENGTH_VALUES = ["0", "-550", "1e308", "1e-320", "100000", "0.001"]
SIGMA_VALUES = ["0", "-0.01", "1e-320", "1e308", "-0", "5e-324"]
VALUE_VALUES = ["-1", "-1e308", "1e308", "0", "1e-320", "1e200"]
CHANNELS = ["r", "g", "b", "Red", "X", "", "RG", " R", "R\0", "\u0280", "rgb", "1", "W"]


def _pick_col(t, rnd):
    return rnd.randrange(len(t.header))


def col_delete(t, rnd):
    i = _pick_col(t, rnd)
    name = t.header.pop(i)
    for r in t.rows:
        if i < len(r):
            r.pop(i)
    return f"column {name!r} deleted", False


def col_duplicate(t, rnd):
    i = _pick_col(t, rnd)
    t.header.append(t.header[i])
    for r in t.rows:
        r.append(r[i] if i < len(r) else "")
    return f"column {t.header[i]!r} duplicated at the end", False


def col_rename(t, rnd):
    i = _pick_col(t, rnd)
    old = t.header[i]
    new = rnd.choice([old.upper(), old + " [deg]", old.replace("_", " "), '"' + old + '"',
                      old[:-1], old + "\u200b", old.replace("i", "\u0456", 1),  # Cyrillic i
                      "Theta_i_deg" if old == "theta_i_deg" else old.capitalize(),
                      "wavelength" if old == "wavelength_nm" else old + "_x"])
    if new == old:
        raise ValueError("no change")
    t.header[i] = new
    return f"column {old!r} renamed to {new!r}", False


def col_reorder(t, rnd):
    order = list(range(len(t.header)))
    rnd.shuffle(order)
    t.header = [t.header[i] for i in order]
    t.rows = [[r[i] if i < len(r) else "" for i in order] for r in t.rows]
    return f"columns reordered {order}", True


def col_unknown(t, rnd):
    name = rnd.choice(["note", "sample", "", "value_per_sr_2", "#hash"])
    t.header.append(name)
    for r in t.rows:
        r.append("x")
    return f"an unknown column {name!r} added", False


def col_wavelength_and_channel(t, rnd):
    if t.col("wavelength_nm") is not None and t.col("channel") is None:
        t.header.append("channel")
        for r in t.rows:
            r.append("G")
        return "a channel column beside wavelength_nm", False
    if t.col("channel") is not None and t.col("wavelength_nm") is None:
        t.header.append("wavelength_nm")
        for r in t.rows:
            r.append("550")
        return "a wavelength_nm column beside channel", False
    raise ValueError


def rows_short(t, rnd):
    which = rnd.choice(["one row", "every row", "the last row"])
    targets = t.rows if which == "every row" else [t.rows[-1]] if which == "the last row" else [
        rnd.choice(t.rows)]
    for r in targets:
        if r:
            r.pop()
    return f"{which}: last cell missing", False


def rows_long(t, rnd):
    which = rnd.choice(["one row", "every row"])
    targets = t.rows if which == "every row" else [rnd.choice(t.rows)]
    extra = rnd.choice(["1", "", "x", ",,,"])
    for r in targets:
        r.append(extra)
    return f"{which}: an extra cell {extra!r}", False


def rows_empty_cells(t, rnd):
    r = rnd.choice(t.rows)
    r[:] = [""] * len(r)
    return "a row of empty cells (only commas)", False


def cell_value(t, rnd):
    i = _pick_col(t, rnd)
    name = t.header[i]
    pool = {"theta_i_deg": ANGLE_VALUES, "theta_o_deg": ANGLE_VALUES, "phi_i_deg": PHI_VALUES,
            "phi_o_deg": PHI_VALUES, "wavelength_nm": WAVELENGTH_VALUES,
            "sigma_per_sr": SIGMA_VALUES, "value_per_sr": VALUE_VALUES,
            "channel": CHANNELS}.get(name, [])
    v = rnd.choice(pool + BAD_NUMBERS if pool and rnd.random() < 0.6 else BAD_NUMBERS)
    where = rnd.choice(["first row", "a random row", "every row", "the last row"])
    rows = t.rows if where == "every row" else [t.rows[0]] if where == "first row" else [
        t.rows[-1]] if where == "the last row" else [rnd.choice(t.rows)]
    for r in rows:
        if i < len(r):
            r[i] = v
    shown = v if len(v) < 40 else f"{v[:8]}... ({len(v)} chars)"
    return f"column {name!r}, {where}: {shown!r}", False


def header_twice(t, rnd):
    at = rnd.randrange(len(t.rows) + 1)
    t.rows.insert(at, list(t.header))
    return f"the header line repeated before data row {at}", False


def header_missing(t, rnd):
    t.header = t.rows.pop(0)
    return "no header line (the first line is data)", False


def no_rows(t, rnd):
    how = rnd.choice(["header only", "comments only", "empty file", "a single newline"])
    if how == "header only":
        t.rows = []
    elif how == "comments only":
        t.raw_lines = t.comments or ["# nothing"]
    elif how == "empty file":
        t.byte_ops.append(lambda b: b"")
    else:
        t.byte_ops.append(lambda b: b"\n")
    return f"no data: {how}", False


def line_ends(t, rnd):
    how = rnd.choice(["CRLF", "CR only (classic Mac)", "mixed LF and CRLF", "LF CR"])
    if how == "CRLF":
        t.newline = "\r\n"
        return "CRLF line ends", True
    if how.startswith("CR only"):
        t.newline = "\r"
    elif how.startswith("mixed"):
        t.byte_ops.append(lambda b: b.replace(b"\n", b"\r\n", 5))
    else:
        t.newline = "\n\r"
    return f"line ends: {how}", False


def encoding(t, rnd):
    how = rnd.choice(["UTF-8 BOM", "UTF-16 LE with BOM", "Latin-1 degree sign in a comment",
                      "NUL byte in a cell", "NUL bytes after the header", "invalid UTF-8 in a cell",
                      "a NUL-only line", "Unicode in a comment"])
    if how == "UTF-8 BOM":
        t.byte_ops.append(lambda b: b"\xef\xbb\xbf" + b)
    elif how.startswith("UTF-16"):
        t.byte_ops.append(lambda b: b"\xff\xfe" + b.decode("utf-8", "replace").encode("utf-16-le"))
    elif how.startswith("Latin-1"):
        t.comments.append("# measured at 20\xb0C")
        t.byte_ops.append(lambda b: b.replace("20\xb0C".encode(), b"20\xb0C"))
    elif how == "NUL byte in a cell":
        r = rnd.choice(t.rows)
        r[rnd.randrange(len(r))] += "\0"
    elif how == "NUL bytes after the header":
        t.byte_ops.append(lambda b: b.replace(b"\n", b"\n\0\0\0\n", 1 + (not t.comments)))
    elif how == "invalid UTF-8 in a cell":
        r = rnd.choice(t.rows)
        r[0] = r[0] + "\udcff"
    elif how == "a NUL-only line":
        t.rows.insert(rnd.randrange(len(t.rows)), ["\0" * 7])
    else:
        t.comments.append("# échantillon 日本 \U0001f426")
        return f"encoding: {how}", True
    return f"encoding: {how}", how == "UTF-8 BOM"  # Excel's "CSV UTF-8" starts with a BOM


def separators(t, rnd):
    how = rnd.choice(["tabs", "semicolons", "comma and space", "spaces around cells",
                      "trailing comma on every line", "quoted cells"])
    if how == "tabs":
        t.separator = "\t"
    elif how == "semicolons":
        t.separator = ";"
    elif how == "comma and space":
        t.separator = ", "
        return "separator ', '", True
    elif how == "spaces around cells":
        t.header = [f"  {h} " for h in t.header]
        t.rows = [[f" {c}  " for c in r] for r in t.rows]
        return "spaces around every cell", True
    elif how == "trailing comma on every line":
        t.header.append("")
        t.rows = [r + [""] for r in t.rows]
    else:
        t.header = [f'"{h}"' for h in t.header]
        t.rows = [[f'"{c}"' for c in r] for r in t.rows]
    return f"separator: {how}", False


def blank_and_comments(t, rnd):
    how = rnd.choice(["blank lines between rows", "indented comment", "comment after data",
                      "whitespace-only lines"])
    if how == "blank lines between rows":
        t.rows = [x for r in t.rows for x in (r, [""])]
        return how, True
    if how == "indented comment":
        t.rows.insert(1, ["   # indented comment"])
        return how, True
    if how == "comment after data":
        t.rows[0] = t.rows[0][:-1] + [t.rows[0][-1] + " # note"]
        return "a trailing '# note' after the last cell of the first row", False
    t.rows.insert(2, ["   \t "])
    return how, True


def huge_rows(t, rnd):
    n = rnd.choice([100_000, 200_000, 500_000, 1_000_000])
    bad = n > 200_000 or rnd.random() < 0.3
    t.repeat_rows, t.bad_last_row = n, bad
    return f"{n} rows (the seed's rows repeated){'; the last row bad' if bad else ''}", False


def huge_line(t, rnd):
    how = rnd.choice(["a 10 MB comment line", "a 10 MB cell of digits", "a 10 MB header name",
                      "a 10 MB line of commas", "a header of 100000 columns"])
    ten = 10 * 1024 * 1024
    if how == "a 10 MB comment line":
        t.comments.append("#" + "c" * ten)
    elif how == "a 10 MB cell of digits":
        r = rnd.choice(t.rows)
        r[-1] = "1" * ten
    elif how == "a 10 MB header name":
        t.header[-1] = t.header[-1] + "x" * ten
    elif how == "a 10 MB line of commas":
        t.rows.insert(rnd.randrange(len(t.rows)), ["" for _ in range(ten)])
    else:
        t.header = t.header + [f"c{i}" for i in range(100_000)]
    return how, False


def truncated(t, rnd):
    t.byte_ops.append(lambda b: b[: max(1, int(len(b) * rnd.choice([0.3, 0.7, 0.99])))])
    return "file truncated mid-line", False


OPS = [(col_delete, 2), (col_duplicate, 1), (col_rename, 1.5), (col_reorder, 1), (col_unknown, 1),
       (col_wavelength_and_channel, 0.7), (rows_short, 1.5), (rows_long, 1.5),
       (rows_empty_cells, 0.7), (cell_value, 6), (header_twice, 1), (header_missing, 0.7),
       (no_rows, 0.7), (line_ends, 1), (encoding, 1.5), (separators, 1),
       (blank_and_comments, 0.8), (huge_rows, 0.5), (huge_line, 0.5), (truncated, 0.5)]


def mutate(path, rnd: random.Random, count):
    with open(path, encoding="utf-8") as fh:
        t = Table(fh.read())
    done = []
    tries = 0
    while len(done) < count and tries < 30:
        tries += 1
        op = weighted(rnd, OPS)
        if not t.rows or not t.header:
            break
        try:
            desc, variant = op(t, rnd)
        except (ValueError, IndexError):
            continue
        done.append((desc, variant, op.__name__))
    with open(path, "wb") as fh:
        fh.write(t.render())
    return path, done
