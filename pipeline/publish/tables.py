"""Data files of a run: the energy dataset (as the paper's newenergy.txt) and the regression front."""

from __future__ import annotations

from pathlib import Path

from ..engine.exponents import n_range
from ..symbolic.regress import write_front_csv


def write(out: Path, config, results) -> None:
    """newenergy.csv, energy_all_n.csv, symbolic_front.csv and regression_front.csv, each where the
    stages it is read from ran (a targeted run writes those of its stages)."""
    n_all = n_range(config)
    if "energy_dataset" in results:
        data = results["energy_dataset"]
        with open(out / "newenergy.csv", "w") as f:
            f.write("n, y\n")
            for n, y in zip(results["sample"]["sample_n"], data["sample_y"]):
                f.write(f"{int(n)}, {y:.12g}\n")
        with open(out / "energy_all_n.csv", "w") as f:
            f.write("n,Int,y,gran\n")
            for n, i, y, g in zip(n_all, data["Int"], data["y"], data["gran"]):
                f.write(f"{int(n)},{i:.17g},{y:.17g},{g:.17g}\n")
    if "symbolic_regression" in results:
        write_front_csv(out / "symbolic_front.csv", results["symbolic_regression"]["front"])
    if "sparse_regression" in results:
        reg = results["sparse_regression"]
        with open(out / "regression_front.csv", "w") as f:
            f.write("terms,expression,rms_sample,rms_all_n,threshold\n")
            f.write(f"1,{reg['constant_model']:.6g},{reg['constant_model_rms']:.6g},,\n")
            for m in reg["front"]:
                f.write(f"{len(m['terms'])},{m['expression']},{m['rms']:.6g},{m['rms_all_n']:.6g},"
                        f"{m['threshold']:.3g}\n")


def front_markdown(reg) -> str:
    rows = ["| terms | expression | RMS on the sample | RMS on every n |", "|---|---|---|---|",
            f"| 1 | {reg['constant_model']:.6g} (sample mean) | {reg['constant_model_rms']:.6g} | |"]
    for m in reg["front"]:
        rows.append(f"| {len(m['terms'])} | {m['expression']} | {m['rms']:.6g} | {m['rms_all_n']:.6g} |")
    return "\n".join(rows)
