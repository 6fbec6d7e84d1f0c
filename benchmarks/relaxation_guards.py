"""Experiment (issue 15, session 56): when to lower the relaxation of a case whose η does not
fall — the stagnation check's window, and an oscillation check.

b1-9 at gap 0, μ2 = 0.15, warm-started from gap 0.01 under the studies' rule: η alternates
between 1.35e-5 and 1.33e-5 from iteration 75 until the stagnation check (every
``stagnation_window`` = 100 iterations) lowers ω to 0.8 at 200; then it converges in 50
(docs/convergence.md, session 56). This runs that case, and optionally a study, with
``LatinOptions`` defaults changed in the process (``--set NAME=VALUE``, e.g.
``stagnation_window=30``), so that studies from the command line take them too:

    python benchmarks/relaxation_guards.py [--set stagnation_window=30] [--no-watch] \\
        [-- study b1 --grid mu1=0:0.6:13 --grid mu2=0:0.6:13 --compare --out DIR --no-progress]

``--no-watch``: without the adopted watch (``latin.oscillation``: ω lowered where η
alternates without falling and s goes back and forth; ``iteration.OSCILLATIONS``). The
check on η alone measured in session 56 (``guards.damp_oscillating``, not adopted) is
commit 77c4d52: ``git worktree add /tmp/osc 77c4d52`` and the same command with
``PYTHONPATH=/tmp/osc/src``.
"""

from __future__ import annotations

import argparse
import inspect
import sys

import multilatin as ml
from multilatin.cli import main as cli_main
from multilatin.latin import LatinOptions, iteration, solve_latin
from multilatin.latin.options import STUDY_QOI_RTOL


def set_default(name: str, value: str) -> None:
    """``LatinOptions``' default of ``name`` set to ``value`` (int, float or str)."""
    init = LatinOptions.__init__
    current = getattr(LatinOptions(), name)
    converted = type(current)(value)
    if init.__kwdefaults__ and name in init.__kwdefaults__:
        init.__kwdefaults__[name] = converted
    else:
        names = list(inspect.signature(init).parameters)[1:]
        defaults = list(init.__defaults__ or ())
        defaults[names.index(name) - (len(names) - len(defaults))] = converted
        init.__defaults__ = tuple(defaults)
    assert getattr(LatinOptions(), name) == converted


#: the case: model, its parameters, and those of the neighbour it starts from
CASE = ("b1-9", {"gap": 0.0, "mu2": 0.15}, {"gap": 0.01, "mu2": 0.15})


def warm_case() -> None:
    """The case from its neighbour and cold, under the studies' rule."""
    name, parameters, neighbour = CASE
    model = ml.load_model(name)
    options = LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    line = []
    for label, start in (("warm from gap 0.01", neighbour), ("cold", None)):
        initial = None
        if start is not None:
            fields = solve_latin(model.assemble(start), options).interface
            assert fields is not None
            initial = (fields.displacement_hat, fields.force_hat)
        result = solve_latin(model.assemble(parameters), options, initial=initial)
        line.append(f"{label} {result.iterations} iterations (R_stop "
                    f"{result.qoi['R_stop']:.4f} N)")
    print(f"{name} at {parameters}: " + ", ".join(line), flush=True)


def main() -> None:
    argv = sys.argv[1:]
    study = argv[argv.index("--") + 1:] if "--" in argv else []
    own = argv[:argv.index("--")] if "--" in argv else argv
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    parser.add_argument("--no-watch", action="store_true", help="without latin.oscillation")
    args = parser.parse_args(own)
    if args.no_watch:
        iteration.OSCILLATIONS = False
    for item in args.set:
        name, _, value = item.partition("=")
        set_default(name, value)
    warm_case()
    if study:
        sys.exit(cli_main(study))


if __name__ == "__main__":
    main()
