"""Command line: `pipeline reproduce`, `pipeline refit`, `pipeline keys`.

Exit codes: 0 all checks pass; 1 a check failed or a solver did not converge; 2 bad config or
arguments (nothing computed, nothing written).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from . import checks as checks_mod
from . import paths
from .config import ConfigError, key_table, load_config
from .roots import SolverError


def _print_checks(outcome) -> None:
    if outcome.checks:
        print()
        print(checks_mod.table(outcome.checks))
        for c in outcome.checks:
            if c.verdict == checks_mod.DIFFERS:
                print(f"  {c.expectation.id} differs from the paper: {c.expectation.known_difference}")
    if outcome.failed:
        print(f"\n{len(outcome.failed)} check(s) FAILED: " + ", ".join(c.expectation.id for c in outcome.failed))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="pipeline", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    rep = sub.add_parser("reproduce", help="run the paper's derivation (configs/paper.toml)")
    rep.add_argument("--config", default=str(paths.PAPER_CONFIG))
    ref = sub.add_parser("refit", help="rerun the derivation with another config and --set overrides")
    ref.add_argument("--config", required=True)
    ref.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    ref.add_argument("--out", default=None, metavar="NAME", help="output folder name under outputs/")
    sub.add_parser("keys", help="print every config key with its default and allowed values")
    args = parser.parse_args(argv)
    if args.command == "keys":
        print(key_table())
        return 0

    from .run import run_derivation  # imports JAX; kept out of `keys` and argument errors

    start = time.perf_counter()
    try:
        if args.command == "reproduce":
            config = load_config(args.config)
            baseline = None
        else:
            config = load_config(args.config, tuple(args.overrides), name=args.out)
            if config.name == "paper":
                raise ConfigError("config key 'run.name' = 'paper' is not allowed for a refit: "
                                  "the paper's outputs are written only by `make reproduce`; "
                                  "set run.name or --out")
            paper = load_config(paths.PAPER_CONFIG)
        print(f"config {config.source}: run '{config.name}'")
        if args.command == "refit":
            print("paper's run (for the comparison):")
            baseline = run_derivation(paper, write_outputs=False)
            print(f"run '{config.name}':")
        outcome = run_derivation(config, baseline=baseline)
    except ConfigError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except SolverError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    _print_checks(outcome)
    print(f"\n{'recomputed: ' + ', '.join(outcome.computed) if outcome.computed else 'nothing recomputed'}; "
          f"report: {Path(outcome.out_dir) / 'report.md'}; {time.perf_counter() - start:.1f} s")
    return 1 if outcome.failed else 0


if __name__ == "__main__":
    sys.exit(main())
