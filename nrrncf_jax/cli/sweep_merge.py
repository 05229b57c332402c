"""``nrrncf sweep-merge PART.csv ... --out ALL.csv``: join the parts of a sharded sweep
(``nrrncf sweep --shard K/N --out PART.csv``) into one CSV in case order, checking that every
case of the grid is there exactly once (``studies.distributed.merge_parts``)."""

from . import _common


def _merge(args) -> int:
    import os

    from ..studies.distributed import merge_parts

    for p in args.parts:
        if not os.path.isfile(p):
            raise ValueError(f"no such part: {p}")
    n = merge_parts(args.parts, args.out)
    print(f"nrrncf sweep-merge: {n} cases from {len(args.parts)} parts -> {args.out}")
    return 0


def _check(args) -> None:
    _common.output_path("--out", args.out)


def register(sub) -> None:
    s = sub.add_parser("sweep-merge", help="join the CSV parts of a sharded sweep (sweep --shard K/N)",
                       description="Join the CSV parts of a sharded sweep into one CSV in case order; every case "
                                   "must be in exactly one part.", formatter_class=_common.HelpFormatter)
    s.add_argument("parts", nargs="+", help="the parts' CSV files")
    s.add_argument("--out", required=True, help="the merged CSV")
    s.set_defaults(func=_merge, check=_check)
