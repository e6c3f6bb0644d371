"""``python -m dexcut batch ...``: batch runs on Dask (see :mod:`dexcut.batch`)."""
import sys

from .batch import main


def _main(argv):  # type: ignore[no-untyped-def]
    if not argv or argv[0] != "batch":
        print("usage: python -m dexcut batch simulate|optimize JOB_OR_PROGRAM... --out DIR [--address ADDR] [--set KEY=V1,V2]", file=sys.stderr)
        return 2
    return main(argv[1:])


sys.exit(_main(sys.argv[1:]))
