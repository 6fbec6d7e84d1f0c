"""Tables, figures and the self-contained HTML report of a study (paper §7, tables 1–2,
figures 12, 13, 15)."""

from __future__ import annotations

import base64
import csv
import html
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from ..io.modelfile.checks import CASE_FLAGS, CASE_NUMBERS, CASE_TEXTS  # noqa: E402
from ..io.output import safe_file_name  # noqa: E402
from ..latin.tracking import SETTLED  # noqa: E402
from ..parameters import label  # noqa: E402
from .runner import StudyResult  # noqa: E402


def case_table(result: StudyResult) -> tuple[list[str], list[list[Any]]]:
    """One row per case in traversal order: parameters, iterations and time normalised by
    the first cold computation (the paper's unit; by the first computation when no cold run),
    for each mode run, and the quantities of interest with their estimated errors — a QoI
    over the load steps by its last step's value (``u_A at step 15 [mm]``; every step is in
    study.nc)."""
    main = result.main_mode
    rows_main = result.mode_records(main)
    cold = {r["number"]: r for r in result.mode_records("cold")}
    unit = (cold[0]["wall_s"] if 0 in cold else rows_main[0]["wall_s"])
    names = list(result.plan.grid)
    qois = list(rows_main[0]["qoi"])
    errors = [q for q in qois if q in rows_main[0].get("qoi_error", {})]
    units = {str(n): str(v.attrs.get("units", "")) for n, v in result.dataset.variables.items()}
    header = ["case", *[label(n, units.get(n, "")) for n in names], "iterations",
              "time / first cold"]
    if main == "multiresolution" and cold:
        header += ["cold iterations", "cold time / first cold"]
    header += [label(_column(q, rows_main[0]["qoi"][q]), units.get(q, "")) for q in qois]
    header += [label(_column(f"{q}_err", rows_main[0]["qoi"][q]), units.get(q, ""))
               for q in errors]
    header += ["converged", "unique", "start"]
    rows = []
    for record in rows_main:
        row: list[Any] = [record["number"] + 1, *[record["params"][n] for n in names],
                          record["iterations"], record["wall_s"] / unit]
        if main == "multiresolution" and cold:
            other = cold.get(record["number"])
            row += ([other["iterations"], other["wall_s"] / unit] if other else ["", ""])
        # no answer from a case that did not converge: masked, as in study.nc
        row += [_or_nan(_last(record["qoi"][q])) if record["converged"] else float("nan")
                for q in qois]
        row += [_or_nan(_last(record["qoi_error"].get(q))) if record["converged"]
                else float("nan") for q in errors]
        row += [record["converged"], record.get("unique", True), record["start"]]
        rows.append(row)
    return header, rows


def _column(name: str, value: Any) -> str:
    """A column's name: a QoI over the load steps by its last step."""
    return _at_step(name, len(value)) if isinstance(value, list) else name


def _at_step(name: str, step: int) -> str:
    """A QoI over the load steps, shown at one of them (the tables', the figures' label)."""
    return f"{name} at step {step}"


def _last(value: Any) -> Any:
    """A QoI's value, its last step's for one over the load steps."""
    return (value[-1] if value else None) if isinstance(value, list) else value


def _or_nan(value: Any) -> float:
    return float("nan") if value is None else float(value)


def summary_lines(result: StudyResult) -> list[str]:
    main = result.main_mode
    records = result.mode_records(main)
    failed = [r for r in result.records if not r["converged"]]
    lines = [
        f"{len(records)} cases ({' x '.join(str(n) for n in result.plan.grid.shape)} grid over "
        f"{', '.join(result.plan.grid)}), {len(result.plan.chains)} chain(s), mode {main}",
        f"{main} study: {result.elapsed_s[main]:.2f} s, "
        f"{sum(r['iterations'] for r in records)} iterations in all, peak memory "
        f"{max((r.get('peak_rss_mb', float('nan')) for r in result.records), default=0):.0f} MiB",
    ]
    if result.mode_records("cold") and main == "multiresolution":
        gains = result.gains or {}
        cold = result.mode_records("cold")
        lines.append(f"cold (every case standalone, from zero): sum of times "
                     f"{sum(r['wall_s'] for r in cold):.2f} s, "
                     f"{sum(r['iterations'] for r in cold)} iterations in all")
        if not gains:
            lines.append("gain: not measured (no case converged in both modes)")
        else:
            over = ("" if gains["gain_cases"] == len(cold) else
                    f" (over the {gains['gain_cases']:.0f} of {len(cold)} cases converged "
                    "in both modes)")
            lines.append(f"gain (sum of cold times / study time) = {gains['gain']:.2f}; "
                         f"paper's definition (cases x first cold time / study time) = "
                         f"{gains['paper_gain']:.2f}; iterations ratio (cold / "
                         f"multiresolution) = {gains['iterations_ratio']:.2f}{over}")
        lines += _agreement_lines(result)
    lines += _error_lines(result, records)
    lines.append("converged: all" if not failed else
                 f"NOT CONVERGED: {len(failed)} case(s) (no answer: QoIs masked, left out of "
                 "the gain): " + "; ".join(r["log"] for r in failed[:5]))
    not_unique = [r for r in records if not r.get("unique", True)]
    if not_unique:
        lines.append(
            f"NOT UNIQUE: {len(not_unique)} case(s) where the discrete problem does not "
            "determine the answer (a body at the friction limit; solved from zero so that "
            "the answer does not depend on the study's order): "
            + ", ".join(_params(r) for r in not_unique[:8])
            + (", ..." if len(not_unique) > 8 else "")
            + _unsettled_note(not_unique))
    partly = [r for r in records if r.get("unique", True) and r.get("qoi_determined")]
    if partly:
        lines.append(
            f"UNDETERMINED: {len(partly)} case(s), unique at the last step, with QoI values "
            "at earlier load steps that the discrete problem does not determine (a body free "
            "to move there; study.nc's <QoI>_determined is false at them), e.g. "
            + _params(partly[0]) + ": "
            + "; ".join(_undetermined_at(name, flags)
                        for name, flags in partly[0]["qoi_determined"].items()))
    sliding = [r for r in records if r.get("large_slips")]
    if sliding:
        lines.append(
            f"LARGE SLIP: {len(sliding)} case(s) whose contacts slide beyond the "
            "small-sliding range (pairs no longer facing: their answers are those of "
            "contacts that did not slide; study.nc's small_sliding is false there), e.g. "
            + _params(sliding[0]) + ": "
            + sliding[0]["large_slips"][0])
    for repair in result.repairs:
        lines.append(f"repaired on resume: {repair}")
    return lines


def _agreement_lines(result: StudyResult) -> list[str]:
    """How far the multiresolution answers lie from the cold ones (``agreement``), and
    whether within what the QoI rule promises (each mode within ``qoi_rtol`` of the tight
    answer: the two within twice that)."""
    within = result.modes_within
    if not within:
        return []
    line = ("multiresolution vs cold, the largest difference over the values both determine "
            "(relative to max(|cold|, 1 % of the QoI's largest |cold|)): "
            + ", ".join(f"{name} {value:.1e}" for name, value in within.items()))
    rtol = result.dataset.attrs.get("qoi_rtol")
    if rtol is None:
        return [line]
    beyond = [name for name, value in within.items() if value > 2.0 * float(rtol)]
    line += f"; the QoI rule promises at most {2.0 * float(rtol):g} (2 x qoi_rtol)"
    if not beyond:
        return [line]
    return [line, f"MODES DISAGREE: {', '.join(beyond)} beyond that bound — a warm start led "
            "elsewhere than a cold solve, or the QoI rule stopped short of its promise: "
            "trust the cold answers, check with a smaller --qoi-rtol, and please report "
            "the case"]


def _params(record: dict[str, Any]) -> str:
    """A case's parameters, as the summary names it: (mu1=0, mu2=0.3)."""
    return "(" + ", ".join(f"{k}={v:g}" for k, v in record["params"].items()) + ")"


def _undetermined_at(name: str, flags: bool | list[bool]) -> str:
    """A QoI's undetermined values, by step for one over the load steps."""
    if not isinstance(flags, list):
        return name
    return f"{name} at step(s) " + ", ".join(str(t + 1) for t, d in enumerate(flags) if not d)


def _unsettled(records: list[dict[str, Any]]) -> int:
    """How many of ``records`` ended on a state still changing by more than ``SETTLED``."""
    return sum((r.get("state_change") or 0.0) > SETTLED for r in records)


def _unsettled_note(records: list[dict[str, Any]]) -> str:
    """Cases whose uniqueness check read a state still changing (a body still sliding in
    the iteration looks free at the friction limit)."""
    unsettled = _unsettled(records)
    return (f" ({unsettled} of them read on a state still changing by more than {SETTLED:g}:"
            " a tighter tol checks them)" if unsettled else "")


def _error_lines(result: StudyResult, records: list[dict[str, Any]]) -> list[str]:
    """The largest estimated error of each QoI over the converged cases (and over the load
    steps of one that has several)."""
    converged = [r for r in records if r["converged"]]
    if not converged:
        return []
    units = {str(n): str(v.attrs.get("units", "")) for n, v in result.dataset.variables.items()}
    parts, missing = [], 0
    for name, value in converged[0]["qoi"].items():
        errors = [r.get("qoi_error", {}).get(name) for r in converged]
        known = [e for e in errors if e is not None]
        missing = max(missing, len(errors) - len(known))
        largest = [np.nanmax(np.asarray(e, dtype=float), initial=0.0) for e in known]
        if known:
            unit = units.get(name, "")
            shown = "" if unit in ("", "1", "-") else f" {unit}"
            steps = " (any step)" if isinstance(value, list) else ""
            parts.append(f"{name} ≤ {max(largest):.3g}{shown}{steps}")
    unsettled = _unsettled(converged)
    if not parts and not unsettled:
        return []
    few = missing - unsettled
    return [("estimated errors (largest over the converged cases): " + ", ".join(parts)
             if parts else "estimated errors: none")
            + (f"; {few} case(s) converged in too few iterations to estimate"
               if few > 0 else "")
            + (f"; {unsettled} case(s) not estimated: their state still changed by more "
               f"than {SETTLED:g} (a tighter tol gives an estimate)" if unsettled else "")]


def format_table(header: list[str], rows: list[list[Any]], max_rows: int = 40) -> str:
    """A plain-text table (the middle rows elided past ``max_rows``)."""
    def cell(value: Any) -> str:
        if isinstance(value, bool):
            return "yes" if value else "NO"
        if isinstance(value, float):
            return f"{value:.4g}"
        return str(value)

    shown: list[list[Any] | None] = list(rows)
    if len(rows) > max_rows:
        shown = [*rows[:max_rows // 2], None, *rows[-max_rows // 2:]]
    cells = [[cell(v) for v in header]] + [[cell(v) for v in r] if r else ["..."] * len(header)
                                           for r in shown]
    widths = [max(len(c[i]) for c in cells) for i in range(len(header))]
    return "\n".join("  ".join(c[i].rjust(widths[i]) for i in range(len(header)))
                     for c in cells)


def write_study_outputs(result: StudyResult, folder: Path) -> list[Path]:
    """table.csv, response-surface and iteration figures, report.html."""
    folder.mkdir(parents=True, exist_ok=True)
    header, rows = case_table(result)
    table_path = folder / "table.csv"
    with table_path.open("w", newline="", encoding="utf-8") as stream:
        writer = csv.writer(stream)
        writer.writerow(header)
        writer.writerows(rows)
    figures = (plot_response(result.dataset, folder, result.main_mode)
               + [plot_iterations(result, folder)])
    report = write_report(result, folder, header, rows, figures)
    return [table_path, *figures, report]


def plot_response(dataset: xr.Dataset, folder: Path, mode: str) -> list[Path]:
    """Each quantity of interest over the varied parameters (one over the load steps at
    its last step): a curve for one, a surface for two (paper fig. 12), small multiples
    over the others beyond."""
    data = dataset.sel(mode=mode)
    varied = [str(d) for d in data["iterations"].dims if data.sizes[d] > 1]
    qois = [str(name) for name in data.data_vars
            if name not in (*CASE_NUMBERS, *CASE_FLAGS, *CASE_TEXTS)
            and not str(name).endswith(("_err", "_determined"))]
    paths = []

    def axis(name: str) -> str:
        shown = (name if "step" not in data[name].dims
                 else _at_step(name, int(data["step"][-1])))
        return label(shown, str(data[name].attrs.get("units", "")))

    # cases whose answer the discrete problem does not determine (a body at the friction
    # limit, ``decomposition.uniqueness``): marked, the value one of several
    flagged = (data["converged"] & ~data["unique"]) if "unique" in data else None

    def mark(ax: Any, panel: xr.DataArray, dims: list[str],
             fixed: dict[str, int] | None = None) -> None:
        """Red × on ``ax`` at the flagged cases of ``panel`` (over ``dims``; ``fixed``: the
        indices of the other varied parameters, a small multiple's)."""
        if flagged is None:
            return
        where = flagged.isel(fixed or {}).sel({d: panel[d] for d in dims})
        where = where.squeeze(drop=True).transpose(*dims)
        points = np.argwhere(where.values)
        if not points.size:
            return
        coords = [where[d].values[points[:, i]] for i, d in enumerate(dims)]
        ax.plot(*(coords if len(dims) == 2 else
                  [coords[0], panel.values[tuple(points.T)]]),
                "x", color="red", ms=6, mew=1.5, clip_on=False, zorder=5, label="not unique")
        if fixed is None:
            ax.legend(loc="best", fontsize=8)

    for name in qois:
        values = data[name].where(data["converged"])
        if "step" in values.dims:
            values = values.isel(step=-1)
        path = folder / f"response_{safe_file_name(name)}.png"  # "R/x": response_R_x.png
        if len(varied) == 0 or not np.isfinite(values.values).any():
            continue
        if len(varied) == 1:
            fig, ax = plt.subplots(figsize=(6, 4))
            curve = values.squeeze(drop=True)
            ax.plot(curve[varied[0]], curve.values, "o-")
            mark(ax, curve, varied)
            ax.set_xlabel(axis(varied[0]))
            ax.set_ylabel(axis(name))
            ax.grid(alpha=0.3)
        elif len(varied) == 2:
            fig = plt.figure(figsize=(11, 4.5))
            surface = values.squeeze(drop=True).transpose(*varied)
            x, y = np.meshgrid(surface[varied[0]].values, surface[varied[1]].values,
                               indexing="ij")
            ax3 = fig.add_subplot(1, 2, 1, projection="3d")
            ax3.plot_surface(x, y, surface.values, cmap="viridis", edgecolor="k", linewidth=0.2)
            ax3.set_xlabel(axis(varied[0]))
            ax3.set_ylabel(axis(varied[1]))
            ax3.set_zlabel(axis(name))
            ax = fig.add_subplot(1, 2, 2)
            contour = ax.contourf(x, y, surface.values, levels=15, cmap="viridis")
            fig.colorbar(contour, ax=ax, label=axis(name))
            mark(ax, surface, varied)
            ax.set_xlabel(axis(varied[0]))
            ax.set_ylabel(axis(varied[1]))
        else:
            # maps over the two parameters with the most values, one panel per value of
            # the others (B2: u_A over the hole position, one map per radius, paper fig. 13)
            by_size = sorted(varied, key=lambda d: -data.sizes[d])
            inner = [d for d in varied if d in by_size[:2]]
            outer = [d for d in varied if d not in inner]
            panels = list(np.ndindex(*[data.sizes[d] for d in outer]))[:25]
            columns = min(5, len(panels))
            rows_n = int(np.ceil(len(panels) / columns))
            fig, axes = plt.subplots(rows_n, columns, figsize=(3.6 * columns + 1, 3.2 * rows_n),
                                     squeeze=False, sharex=True, sharey=True)
            levels = np.linspace(float(values.min()), float(values.max()), 13)
            if not levels[-1] > levels[0]:
                levels = np.linspace(levels[0] - 0.5, levels[0] + 0.5, 13)
            contour = None
            for ax, where in zip(axes.ravel(), panels, strict=False):
                panel = values.isel({d: i for d, i in zip(outer, where, strict=True)})
                panel = panel.squeeze(drop=True).transpose(*inner)
                contour = ax.contourf(panel[inner[0]], panel[inner[1]], panel.values.T,
                                      levels=levels, cmap="viridis")
                ax.set_title(", ".join(f"{d}={float(data[d][i]):g}"
                                       for d, i in zip(outer, where, strict=True)), fontsize=9)
                ax.set_aspect("equal", adjustable="box")
                mark(ax, panel, inner, dict(zip(outer, where, strict=True)))
            for ax in axes.ravel()[len(panels):]:
                ax.set_visible(False)
            if contour is not None:
                fig.colorbar(contour, ax=axes.ravel().tolist(), label=axis(name))
            fig.supxlabel(axis(inner[0]))
            fig.supylabel(axis(inner[1]))
        several = len(varied) > 2 and flagged is not None and bool(flagged.any())
        fig.suptitle(f"{dataset.attrs.get('model', '')}: {axis(name)} over "
                     f"{' × '.join(varied)} ({mode} study)"
                     + ("; ×: not unique" if several else ""))
        if len(varied) <= 2:
            fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths


def plot_iterations(result: StudyResult, folder: Path) -> Path:
    """Iterations and time per case in traversal order, for each mode run."""
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4))
    for mode, style in (("cold", "s-"), ("multiresolution", "o-")):
        records = result.mode_records(mode)
        if not records:
            continue
        numbers = [r["number"] + 1 for r in records]
        ax1.plot(numbers, [r["iterations"] for r in records], style, ms=3, label=mode)
        ax2.plot(numbers, [r["wall_s"] for r in records], style, ms=3, label=mode)
    ax1.set_xlabel("case (traversal order)")
    ax1.set_ylabel("LATIN iterations [–]")
    ax2.set_xlabel("case (traversal order)")
    ax2.set_ylabel("wall time per case [s]")
    fig.suptitle(f"{result.dataset.attrs.get('model', '')}: iterations and time per case")
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
        ax.legend()
    fig.tight_layout()
    path = folder / "iterations.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _geometry_line(names: tuple[str, ...]) -> str:
    """The grid parameters that change an operator, in words."""
    if not names:
        return "no geometric parameter: every case reuses the same operators"
    return "geometric parameters (outer loops, operators rebuilt): " + ", ".join(names)


def write_report(result: StudyResult, folder: Path, header: list[str], rows: list[list[Any]],
                 figures: list[Path]) -> Path:
    """report.html: self-contained (figures embedded)."""
    attrs = result.dataset.attrs
    parts = [
        "<!doctype html><html><head><meta charset='utf-8'>",
        f"<title>multilatin study: {html.escape(str(attrs.get('model', '')))}</title>",
        "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}"
        "table{border-collapse:collapse;font-size:12px}td,th{border:1px solid #ccc;"
        "padding:2px 6px;text-align:right}img{max-width:100%}</style></head><body>",
        f"<h1>{html.escape(str(attrs.get('title', attrs.get('model', ''))))}</h1>",
        f"<p>Command: <code>{html.escape(str(attrs.get('command', '')))}</code></p>",
        "<h2>Parameters</h2><ul>",
        *[f"<li>{html.escape(name)}: {', '.join(f'{v:g}' for v in values)}</li>"
          for name, values in result.plan.grid.items()],
        "</ul>",
        f"<p>Tolerance η &lt; {attrs.get('tolerance')}; chains: {attrs.get('chains')}; "
        f"{html.escape(_geometry_line(result.plan.geometric))}</p>",
        "<h2>Summary</h2><ul>",
        *[f"<li>{html.escape(line)}</li>" for line in summary_lines(result)],
        "</ul><h2>Figures</h2>",
    ]
    for path in figures:
        encoded = base64.b64encode(path.read_bytes()).decode()
        parts.append(f"<p><img alt='{path.name}' src='data:image/png;base64,{encoded}'></p>")
    parts.append("<h2>Cases</h2><table><tr>" +
                 "".join(f"<th>{html.escape(h)}</th>" for h in header) + "</tr>")
    for row in rows:
        parts.append("<tr>" + "".join(
            f"<td>{v:.5g}</td>" if isinstance(v, float) else f"<td>{html.escape(str(v))}</td>"
            for v in row) + "</tr>")
    parts.append("</table><p>Data: <code>study.nc</code> (xarray), <code>cases.jsonl</code> "
                 "(one record per case), <code>table.csv</code>.</p></body></html>")
    path = folder / "report.html"
    path.write_text("\n".join(parts), encoding="utf-8")
    return path

