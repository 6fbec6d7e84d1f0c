"""What the cases that are not unique cost a multiresolution study (issue 16): a warm start
whose answer is not unique is set aside and the case solved again from zero (the answer must
not depend on the study's path), so its warm attempt is spent for nothing.

    python benchmarks/warm_attempts.py                 # the main job: B1 13 x 13
    python benchmarks/warm_attempts.py --model b1-9

Runs the study in both modes (``--compare``'s multiresolution and cold) and prints, per case
solved again from zero, its study iterations (warm attempt + solve from zero) against its
cold solve, and the warm attempts' share of the study's iterations.
"""

from __future__ import annotations

import argparse
import tempfile
import warnings

import multilatin as ml


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="b1")
    parser.add_argument("--grid", nargs="+", default=["mu1=0:0.6:13", "mu2=0:0.6:13"])
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    with tempfile.TemporaryDirectory() as folder:
        result = ml.run_study(ml.load_model(args.model), ml.Grid.parse(args.grid), out=folder,
                              progress=False, modes=("multiresolution", "cold"))
    multi = {r["number"]: r for r in result.records if r["mode"] == "multiresolution"}
    cold = {r["number"]: r for r in result.records if r["mode"] == "cold"}
    print("| case | study iterations | cold | warm attempt |")
    print("|---|---|---|---|")
    wasted = 0
    for number, record in sorted(multi.items()):
        if "not unique" not in str(record["start"]):
            continue
        attempt = record["iterations"] - cold[number]["iterations"]
        wasted += attempt
        params = ", ".join(f"{k}={v:g}" for k, v in record["params"].items())
        print(f"| {params} | {record['iterations']} | {cold[number]['iterations']} | {attempt} |")
    total = sum(r["iterations"] for r in multi.values())
    total_cold = sum(r["iterations"] for r in cold.values())
    print(f"\nwarm attempts set aside: {wasted} of the study's {total} iterations "
          f"({100 * wasted / total:.1f} %); cold {total_cold}: iteration ratio "
          f"{total_cold / total:.2f}, {total_cold / (total - wasted):.2f} without them")


if __name__ == "__main__":
    main()
