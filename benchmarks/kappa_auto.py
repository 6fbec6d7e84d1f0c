"""What ``--kappa auto`` chooses on the bundled models (sessions 38, 49): the study's probe
(``study.kappa.choose_kappa``) on each model's central case of a typical grid, with the
grid's corners handed over as the CLI hands them (last values, then first ones), under the
studies' stopping rule. One line per model, as a study prints it.

    python benchmarks/kappa_auto.py [--models b1 lap ...]
"""

from __future__ import annotations

import argparse

import multilatin as ml
from multilatin.latin import LatinOptions
from multilatin.latin.options import STUDY_QOI_RTOL
from multilatin.study.kappa import choose_kappa

#: per model, a typical grid: (centre, corner of last values, corner of first values)
GRIDS: dict[str, tuple[dict[str, float], ...]] = {
    "b1": ({"mu1": 0.3, "mu2": 0.3}, {"mu1": 0.6, "mu2": 0.6}, {"mu1": 0.0, "mu2": 0.0}),
    "b1-9": ({"mu1": 0.3, "mu2": 0.3}, {"mu1": 0.6, "mu2": 0.6}, {"mu1": 0.0, "mu2": 0.0}),
    "b3": ({"xc": 25.0, "yc": 75.0, "rc": 3.0}, {"xc": 27.0, "yc": 77.0, "rc": 3.0},
           {"xc": 23.0, "yc": 73.0, "rc": 3.0}),
    "punch": ({"mu": 0.3, "position": 30.0}, {"mu": 0.5, "position": 40.0},
              {"mu": 0.1, "position": 10.0}),
    "slide": ({"mu": 0.3}, {"mu": 0.5}, {"mu": 0.1}),
    "lap": ({"mu": 0.25, "p": 50.0}, {"mu": 0.4, "p": 80.0}, {"mu": 0.1, "p": 20.0}),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--models", nargs="+", default=list(GRIDS), choices=list(GRIDS))
    args = parser.parse_args()
    options = LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    for name in args.models:
        centre, *corners = GRIDS[name]
        choice = choose_kappa(ml.load_model(name), centre, options, others=corners)
        print(f"{name}: {choice.describe()}")


if __name__ == "__main__":
    main()
