"""The long-lived `plumage.read_record` worker of fuzz/structure/fuzz_user_data.py.

Reads one JSON request per line on stdin ({"path": ...}), reads that file with
plumage.read_record and answers one line on stdout, prefixed with RESULT_MARK:
{"status": "ok" | "rejected" | "exception", "type": ..., "message": ..., "traceback": ...}.
"rejected" is a documented error (plumage.records.RecordError, FileNotFoundError); anything
else is "exception". A crash (a signal inside h5py or HDF5) or a hang ends or stalls the worker:
the driver sees it, attributes it to the file it sent last and starts another worker.

    /usr/bin/python3 read_worker.py [--memory-limit-mb N]
"""

import json
import os
import resource
import sys
import traceback

RESULT_MARK = "@@read_record@@ "


def main():
    args = sys.argv[1:]
    if len(args) == 2 and args[0] == "--memory-limit-mb" and int(args[1]) > 0:
        limit = int(args[1]) * 1024 * 1024
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    out = sys.stdout
    sys.stdout = sys.stderr  # anything the library prints stays off the answer channel
    import plumage
    from plumage.records import RecordError

    allowed = (RecordError, FileNotFoundError)
    out.write(RESULT_MARK + json.dumps({"status": "ready", "module": plumage.__file__}) + "\n")
    out.flush()
    for line in sys.stdin:
        if not line.strip():
            continue
        path = json.loads(line)["path"]
        try:
            rec = plumage.read_record(path)
            repr(rec)
            answer = {"status": "ok", "kind": str(getattr(rec, "kind", ""))}
        except allowed as e:
            answer = {"status": "rejected", "type": type(e).__name__, "message": str(e)[:2000]}
        except BaseException as e:  # noqa: B902 - every other exception is a finding
            answer = {"status": "exception", "type": f"{type(e).__module__}.{type(e).__name__}",
                      "message": str(e)[:2000], "traceback": traceback.format_exc()[-6000:]}
        out.write(RESULT_MARK + json.dumps(answer) + "\n")
        out.flush()
    return 0


if __name__ == "__main__":
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    sys.exit(main())
