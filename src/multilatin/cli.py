"""The ``multilatin`` command line.

Exit status: 0 success, 2 bad input (message names the field and value), 3 the LATIN
iteration did not converge within its cap (the unconverged state is reported, never as an
answer).

The top room: may import every other; imports the solvers, the study engine and the plots
only when a command needs them, so that ``multilatin models`` or ``--help`` stay quick.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
from pathlib import Path

from . import __version__
from .decomposition.result import SolveResult
from .errors import ModelError, NotConvergedError
from .io.describe import (
    body_force_lines,
    boundary_lines,
    contact_lines,
    point_load_lines,
    qoi_reads,
    temperature_lines,
)
from .io.files import ensure_writable_folder
from .latin import LatinOptions
from .latin.options import ACCELERATIONS, BACKENDS, STUDY_QOI_RTOL
from .limits import MEMORY_ENVIRONMENT
from .model import REFERENCE_MESHES, Model, bundled_models, load_model
from .parameters import label, parse_assignments

EXIT_BAD_INPUT = 2
EXIT_NOT_CONVERGED = 3

log = logging.getLogger("multilatin")


def _parse_split(items: list[str]) -> dict[str, tuple[int, int]]:
    out = {}
    for item in items:
        body, sep, text = item.partition("=")
        nx, x, ny = text.partition("x")
        if not sep or not x or not nx.isdigit() or not ny.isdigit() or int(nx) < 1 or int(ny) < 1:
            raise ModelError(f"--split {item!r}: expected body=NXxNY, e.g. beam=20x1")
        out[body] = (int(nx), int(ny))
    return out


def _add_model_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", help="bundled model name (see `multilatin models`) or a .toml path")
    parser.add_argument("--set", dest="assignments", action="append", default=[],
                        metavar="NAME=VALUE", help="set a model parameter (repeatable)")
    parser.add_argument("--refine", type=int, default=1,
                        help="multiply every element count by this factor")
    parser.add_argument("--split", action="append", default=[], metavar="BODY=NXxNY",
                        help="override the number of substructures of a body")
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object on standard output")
    parser.add_argument("--out", type=Path, help="write VTK fields, tables and plots here")
    _add_memory_argument(parser)


def _add_memory_argument(parser: argparse.ArgumentParser, default: object = argparse.SUPPRESS
                         ) -> None:
    parser.add_argument("--max-memory-gb", type=float, default=default, metavar="GB",
                        help="refuse models and studies estimated to need more memory "
                        "(default: 80%% of the memory available; or MULTILATIN_MAX_MEMORY_GB)")


def _optional_rtol(text: str) -> float | None:
    return None if text.strip().lower() in ("none", "off") else float(text)


def _kappa(text: str) -> float | str:
    """--kappa: a number, or ``auto`` (a study's, chosen on its central case)."""
    return "auto" if text.strip().lower() == "auto" else float(text)


def _add_latin_arguments(parser: argparse.ArgumentParser, qoi_rtol: float | None = None
                         ) -> None:
    d = LatinOptions()
    parser.add_argument("--kappa", type=_kappa, default=d.kappa,
                        help="search direction k = κE/L; the answer does not depend on it, "
                        "the iterations do. 'auto' (study): the κ of 0.5, 1, 2, 5, 10 that "
                        "solves the grid's central case in the fewest iterations; 0.25, 0.1 "
                        "where 0.5 is best there and they are no slower on the grid's "
                        "corners (default: %(default)s)")
    parser.add_argument("--tol", type=float, default=d.tol,
                        help="tolerance on the indicator η (default: %(default)s)")
    # a study's default depends on --acceleration (``_qoi_rtol``): absent unless given
    parser.add_argument("--qoi-rtol", type=_optional_rtol, metavar="RTOL",
                        default=argparse.SUPPRESS if qoi_rtol is not None else None,
                        help="also stop a case once every QoI's estimated error is below RTOL "
                        "times its value, and the state's remaining change η/(1-ρ) below RTOL; "
                        "'none': on η alone (default: " + (
                            f"{qoi_rtol:g} with --acceleration relaxation, none with the "
                            "others, whose steps leave no QoI estimate" if qoi_rtol is not None
                            else "none") + ")")
    parser.add_argument("--max-iter", type=int, default=d.max_iter,
                        help="iteration cap (default: %(default)s)")
    parser.add_argument("--relaxation", type=float, default=d.relaxation,
                        help="relaxation ω of the linear stage, in (0, 1] (default: %(default)s)")
    parser.add_argument("--no-macro", action="store_true", help="skip the macro problem")
    parser.add_argument("--acceleration", default=d.acceleration, choices=list(ACCELERATIONS),
                        help="relaxation alone, Anderson mixing, or relaxation with a "
                        "reduced-rank extrapolation every 10 iterations (fewer iterations, "
                        "docs/convergence.md) (default: %(default)s)")
    parser.add_argument("--corner-stiffening", type=float, default=d.corner_stiffening,
                        metavar="FACTOR", help="k times FACTOR at the nodes where two "
                        "interfaces of a substructure meet, 1 beyond a fifth of the body's "
                        "size; 1: off (docs/convergence.md) (default: %(default)s)")
    parser.add_argument("--micro-stiffening", type=float, default=d.micro_stiffening,
                        metavar="FACTOR", help="two-scale search direction: k times FACTOR "
                        "on interfaces between substructures and on stops, but on the macro "
                        "part (resultant, moment) of contact sides and stops; 1: off "
                        "(docs/convergence.md) (default: %(default)s)")
    parser.add_argument("--no-sliding-jumps", action="store_true",
                        help="do not extrapolate a block's steady sliding to the stop or "
                        "contact it closes (LatinOptions.extrapolate_sliding)")
    parser.add_argument("--rigid-balance", action="store_true",
                        help="balance each free body's rigid motions after every local "
                        "stage: fewer iterations, each dearer (LatinOptions.rigid_balance, "
                        "docs/convergence.md)")
    parser.add_argument("--settled-steps", type=float, default=d.settled_steps,
                        metavar="FACTOR", help="stop iterating a case's leading load steps "
                        "once each one's share of eta has stayed below FACTOR x tol for 3 "
                        "iterations; 0: every step every iteration (docs/performance.md) "
                        "(default: %(default)s)")
    parser.add_argument("--interface-elements", default=d.interface_elements,
                        choices=["nodal", "edges", "edge-pairs"],
                        help="the interface fields' elements: nodal (the trace nodes' dual "
                        "cells), or for comparison the paper's P0 per mesh edge (B0: 1 384 "
                        "iterations against 66, B1's studies mostly at the cap) or P0 per "
                        "pair of edges (docs/method.md) (default: %(default)s)")
    parser.add_argument("--backend", default=d.backend, choices=list(BACKENDS),
                        help="array library of the iteration: numpy (with Numba; the "
                        "reference) or torch (PyTorch, extra 'gpu') (default: %(default)s)")
    parser.add_argument("--device", default=d.device, metavar="DEVICE",
                        help="where the torch backend works: cpu, cuda or cuda:N "
                        "(default: %(default)s)")
    parser.add_argument("--fuse", action="store_true",
                        help="torch backend: compile the local stage (torch.compile; minutes "
                        "of compilation the first time)")


VERBOSE_HELP = ("more log lines on standard error: -v (INFO) a line per solve, -vv (DEBUG) "
                "the iterations too; before or after the command")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="multilatin",
        description="Parametric studies of elastic assemblies with contact by the "
        "micro-macro LATIN method.",
    )
    parser.add_argument("--version", action="version", version=f"multilatin {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help=VERBOSE_HELP)
    _add_memory_argument(parser, default=None)
    sub = parser.add_subparsers(dest="command", required=True)
    solve = sub.add_parser("solve", help="solve a model with the LATIN micro-macro solver")
    _add_model_arguments(solve)
    _add_latin_arguments(solve)
    solve.add_argument("--with-reference", action="store_true",
                       help="also solve monolithically; report both and overlay the histories")
    ref = sub.add_parser("reference", help="solve a model monolithically (reference)")
    _add_model_arguments(ref)
    for p in (solve, ref):
        p.add_argument("--reference-mesh", choices=REFERENCE_MESHES, default="auto",
                       help="reference on the same meshes, or with holed bodies meshed "
                       "conforming by gmsh (auto: conforming when the model has holes in "
                       "structured rectangles or non-matching interfaces)")
    study = sub.add_parser(
        "study", help="a parametric study over a grid, with multiresolution",
        description="Solve every parameter set of a grid; each case starts from its nearest "
        "converged neighbour (multiresolution) unless --cold. Results go to a folder that a "
        "second run of the same command resumes.")
    study.add_argument("model", help="bundled model name or a .toml path")
    study.add_argument("--grid", action="append", default=[], metavar="NAME=VALUES",
                       help="a varied parameter: name=start:stop:count, name=v1,v2,... or "
                       "name=value (repeatable; a list out of order is sorted)")
    study.add_argument("--set", dest="assignments", action="append", default=[],
                       metavar="NAME=VALUE", help="fix a parameter that is not varied")
    modes = study.add_mutually_exclusive_group()
    modes.add_argument("--cold", action="store_true",
                       help="start every case from zero with its own operators")
    modes.add_argument("--compare", action="store_true",
                       help="run both modes and report the multiresolution gain")
    study.add_argument("--out", type=Path, help="results folder (default: study-<model>)")
    study.add_argument("--json", action="store_true", help="print one JSON object")
    study.add_argument("--workers", type=int, default=0,
                       help="run on a local Dask cluster of N processes (default: 0, in "
                            "this process); on a GPU they share it, each with its share of "
                            "its memory (8: the whole B3 study 2 x faster, docs/gpu.md)")
    study.add_argument("--scheduler", help="run on the Dask cluster at this address")
    study.add_argument("--chains", type=int, default=None,
                       help="independent multiresolution chains (default: 1; with "
                            "--schedule chains, the number of workers)")
    # as --start's: study.plan.SCHEDULES, spelt out (the command line loads no solver early)
    study.add_argument("--schedule", choices=["waves", "chains"], default="waves",
                       help="with --workers/--scheduler: grid lines as tasks, each from the "
                            "neighbour line nearer the middle one (waves; with --start zero "
                            "every batch a task), or contiguous chains from zero (default: "
                            "%(default)s)")
    study.add_argument("--start", choices=["neighbour", "nearest", "zero"], default=None,
                       help="multiresolution: start each case from its nearest converged "
                       "neighbour (along hole positions, neighbours extrapolated: secant, "
                       "parallelogram; along friction lines, its history retimed), from the "
                       "nearest alone, or every case of a geometry from "
                       "zero in batches of --batch sharing the operators (default: "
                       "neighbour; zero with --backend torch --device cuda, faster there)")
    study.add_argument("--batch", type=int, default=None,
                       help="multiresolution: iterate up to N cases together, each from its "
                            "nearest converged neighbour (1: one by one; default: 16; "
                            "4225 on a GPU from zero; on torch over several geometries a "
                            "whole geometry wave, as the memory holds)")
    study.add_argument("--lines", action="store_true",
                       help="serial multiresolution: solve grid lines batch after batch "
                            "instead of one rolling batch that a case joins once its "
                            "neighbour has converged (the same answers)")
    for p in (solve, ref, study):
        p.add_argument("--mortar", action="store_true",
                       help="join the non-matching meshes of interfaces declared type = "
                       "'macro' by mortar projection (micro forces too) instead of macro "
                       "quantities only (paper eq. [20])")
    study.add_argument("--no-progress", action="store_true", help="no progress bar")
    _add_memory_argument(study)
    _add_latin_arguments(study, qoi_rtol=STUDY_QOI_RTOL)
    sub.add_parser("models", help="list the bundled models")
    show = sub.add_parser("show", help="describe a model: parameters, substructures, QoIs")
    show.add_argument("model")
    for command in sub.choices.values():  # -v after the command too (it then counts alone)
        command.add_argument("-v", "--verbose", action="count", default=argparse.SUPPRESS,
                             help=VERBOSE_HELP)
    return parser


def _report(result: SolveResult, args: argparse.Namespace,
            reference: SolveResult | None = None) -> None:
    if args.out is not None:
        from .io.output import write_result  # matplotlib and meshio only when writing
        from .io.plots import plot_histories

        for path in write_result(result, args.out):
            log.info("wrote %s", path)
        if reference is not None:
            plot_histories({"LATIN": result, "monolithic reference": reference},
                           args.out / "history.png")
    if args.json:
        data = result.to_json_dict()
        if reference is not None:
            data["reference"] = {"qoi": reference.qoi, "wall_s": reference.wall_s}
        print(json.dumps(data))
        return
    from .io.result_text import result_lines
    from .latin.tracking import SETTLED  # the solver's modules are loaded by now

    for line in result_lines(result, reference, SETTLED):
        print(line)
    if args.out is not None:
        print(f"results written to {args.out}")


def _show(model: Model) -> None:
    print(f"{model.name}: {model.title}")
    print("parameters:")
    for p in model.parameters.values():
        shown = label(f"{p.default:g}", p.unit)
        print(f"  {p.name} = {shown}  range [{p.minimum:g}, {p.maximum:g}]  {p.description}")
    assembly = model.assemble()
    hypotheses = sorted({sub.material.hypothesis for sub in assembly.substructures})
    print(f"substructures: {len(assembly.substructures)} ({', '.join(hypotheses)}), dofs: "
          f"{assembly.n_dofs}, load steps: {assembly.n_steps}")
    kinds: dict[str, int] = {}
    for itf in assembly.interfaces:
        kinds[itf.kind] = kinds.get(itf.kind, 0) + 1
    print("interfaces: " + ", ".join(f"{n} {k}" for k, n in sorted(kinds.items())))
    for sub in assembly.substructures:
        if sub.cut is not None:
            print(f"hole in {sub.name}: {sub.hole!r} ({sub.cut.cut.size} cut cells, "
                  f"{sub.cut.void.size} void cells, {sub.cut.inactive_nodes.size} nodes removed)")
    contacts = contact_lines(assembly)
    if contacts:
        print("contacts:")
        for line in contacts:
            print(f"  {line}")
    print("boundary conditions:")
    for line in boundary_lines(assembly):
        print(f"  {line}")
    if assembly.body_forces:
        print("body forces:")
        for line in body_force_lines(assembly):
            print(f"  {line}")
    for title, lines in (("temperature changes", temperature_lines(assembly)),
                         ("point loads", point_load_lines(assembly))):
        if lines:
            print(f"{title}:")
            for line in lines:
                print(f"  {line}")
    print("quantities of interest:")
    for q in assembly.qois:
        print(f"  {label(q.name, q.unit)}: {qoi_reads(assembly, q)}")


def _qoi_rtol(args: argparse.Namespace) -> float | None:
    """--qoi-rtol as given; a study's without it: ``STUDY_QOI_RTOL`` with the relaxation,
    η alone with Anderson or RRE (their steps break the estimates the rule reads)."""
    if hasattr(args, "qoi_rtol"):
        given: float | None = args.qoi_rtol
        return given
    if args.acceleration == "relaxation":
        return STUDY_QOI_RTOL
    log.warning("--acceleration %s: the cases stop on eta < %g alone (the QoI rule's "
                "estimates need the relaxation's iterations); their QoIs carry no error "
                "estimate", args.acceleration, args.tol)
    args.qoi_rtol = None  # said once
    return None


def _latin_options(args: argparse.Namespace, kappa: float | None = None) -> LatinOptions:
    """The options of ``args``, with ``kappa`` instead of theirs when given (a study's
    ``--kappa auto``, once chosen)."""
    kappa = args.kappa if kappa is None else kappa
    if kappa == "auto":
        raise ModelError("--kappa auto: chooses the search direction of a study (`multilatin "
                         "study ... --kappa auto`); for one solve give a number (curved "
                         "contacts converge faster at 2-5, B1's models at 0.5)")
    return LatinOptions(kappa=kappa, tol=args.tol, max_iter=args.max_iter,
                        qoi_rtol=_qoi_rtol(args),
                        relaxation=args.relaxation, macro=not args.no_macro,
                        extrapolate_sliding=not args.no_sliding_jumps,
                        rigid_balance=args.rigid_balance,
                        settled_steps=args.settled_steps,
                        corner_stiffening=args.corner_stiffening,
                        micro_stiffening=args.micro_stiffening,
                        acceleration=args.acceleration,
                        interface_elements=args.interface_elements,
                        backend=args.backend, device=args.device, fuse=args.fuse)


def _study(model: Model, args: argparse.Namespace, argv: list[str] | None) -> int:
    from .parameters import Grid
    from .study.report import case_table, format_table, summary_lines, write_study_outputs
    from .study.runner import run_study

    fixed = parse_assignments(args.assignments)
    grid = Grid.parse(args.grid)
    overlap = sorted(set(fixed) & set(grid))
    if overlap:
        raise ModelError(f"--set {overlap[0]}: the parameter is also in --grid")
    if fixed:
        model = model.with_defaults(fixed)
    modes = ("cold",) if args.cold else ("multiresolution", "cold") if args.compare else (
        "multiresolution",)
    out = args.out or Path(f"study-{model.name}")
    command = "multilatin " + " ".join(argv if argv is not None else sys.argv[1:])
    choice = None
    if args.kappa == "auto":
        from .study.kappa import choose_kappa

        centre = {name: values[len(values) // 2] for name, values in grid.items()}
        # where the centre has no equilibrium: the corners of all last, of all first values
        corners = [{name: values[i] for name, values in grid.items()} for i in (-1, 0)]
        choice = choose_kappa(model, centre, _latin_options(args, LatinOptions.kappa),
                              others=[c for c in corners if c != centre])
        if not args.json:
            print(choice.describe())
    options = _latin_options(args, None if choice is None else choice.kappa)
    result = run_study(model, grid, options=options, modes=modes, out=out,
                       chains=args.chains, batch=args.batch, start=args.start,
                       workers=args.workers, scheduler=args.scheduler,
                       schedule=args.schedule, rolling=not args.lines,
                       progress=not args.no_progress and not args.json, command=command)
    written = write_study_outputs(result, out)
    if args.json:
        data = result.to_json_dict()
        if choice is not None:
            data["kappa_auto"] = {"kappa": choice.kappa, "params": choice.params,
                                  "iterations": {f"{k:g}": n
                                                 for k, n in choice.iterations.items()},
                                  "seconds": choice.seconds, "skipped": choice.skipped}
        print(json.dumps(data))
    else:
        header, rows = case_table(result)
        print(format_table(header, rows))
        print()
        for line in summary_lines(result):
            print(line)
        print(f"results in {out}/: study.nc (xarray), table.csv, report.html, "
              + ", ".join(p.name for p in written if p.suffix == ".png"))
    return 0 if all(r["converged"] for r in result.records) else EXIT_NOT_CONVERGED


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    level = logging.WARNING - 10 * args.verbose
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s",
                        stream=sys.stderr)
    # a study's progress: a bar on a terminal, else a log line every few seconds, shown
    # without -v (multilatin.study.runner._LoggedProgress)
    logging.getLogger("multilatin.progress").setLevel(min(level, logging.INFO))
    try:
        if args.max_memory_gb is not None:
            if not args.max_memory_gb > 0 or args.max_memory_gb == float("inf"):
                raise ModelError(f"--max-memory-gb: must be a number of GB > 0, got "
                                 f"{args.max_memory_gb!r}")
            os.environ[MEMORY_ENVIRONMENT] = repr(args.max_memory_gb)
        if args.command == "models":
            for name in bundled_models():
                print(f"{name}: {load_model(name).title}")
            return 0
        model = load_model(args.model)
        if getattr(args, "mortar", False):
            model = model.with_mortar()
        if args.command == "study":
            return _study(model, args, argv)
        if args.command == "show":
            _show(model)
            return 0
        mu = model.parameters.parse(parse_assignments(args.assignments))
        split = _parse_split(args.split)
        if args.out is not None:
            ensure_writable_folder(args.out)
        if args.command == "reference":
            try:
                monolithic = model.reference(mu, refine=args.refine, split=split,
                                             mesh=args.reference_mesh)
            except NotConvergedError as exc:
                print(f"error: {exc}", file=sys.stderr)
                return EXIT_NOT_CONVERGED
            _report(monolithic, args)
            return 0
        options = _latin_options(args)
        try:
            result = model.solve(mu, options=options, refine=args.refine, split=split)
        except NotConvergedError as exc:
            _report(exc.result, args)
            print(f"error: {exc}", file=sys.stderr)
            return EXIT_NOT_CONVERGED
        try:
            reference = (model.reference(mu, refine=args.refine, split=split,
                                         mesh=args.reference_mesh)
                         if args.with_reference else None)
        except NotConvergedError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return EXIT_NOT_CONVERGED
        _report(result, args, reference)
        return 0
    except ModelError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT


def run() -> int:
    """Console entry point: ``main`` with a quiet exit when the reader of stdout goes away
    (``multilatin ... | head``)."""
    try:
        return main()
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(run())
