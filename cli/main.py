"""The ``fibrecut`` command line.

Solver commands live here (scenes, run, verify, bench, plot, plot-mesh, compare,
convergence, stability); study commands (serve, worker, submit, status, results, cancel)
are registered by :mod:`cli.study`. Bad input exits with code 2 and one line
naming the field, the value and what is allowed.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import Any

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_UNSTABLE = 0, 1, 2, 3


class UsageError(Exception):
    """Bad input from the command line: reported on one line, exit code 2."""


def _print_json(obj: Any) -> None:
    """Strict JSON: a value that is not a finite number (NaN: not measured) is written as null."""
    print(json.dumps(_finite(obj), indent=2, default=_json_default, allow_nan=False))


def _finite(o):
    if isinstance(o, float):
        return o if math.isfinite(o) else None
    if isinstance(o, dict):
        return {k: _finite(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_finite(v) for v in o]
    return o


def _json_default(o):
    try:
        import numpy as np

        if isinstance(o, np.integer):
            return int(o)
        if isinstance(o, np.floating):
            return float(o) if math.isfinite(o) else None
        if isinstance(o, np.ndarray):
            return _finite(o.tolist())
    except ImportError:  # pragma: no cover
        pass
    return str(o)


def _load(scene_ref: str, sets: list[str] | None, budget: bool = True):
    """A scene from a built-in name or a YAML/JSON file (size-limited, no YAML aliases), with
    --set overrides; booleans are refused for numbers and, with ``budget``, a scene beyond the
    size limits (solver.budget) is a usage error naming the fields that make it large."""
    from solver.scene import parse_set_options

    return load_checked(scene_ref, parse_set_options(sets or []), budget)


def load_checked(scene_ref: str, overrides: dict, budget: bool = True):
    """:func:`_load` with overrides already parsed (dotted name -> value)."""
    from pathlib import Path

    from service.inputs import YamlError, bool_problems, load_yaml
    from solver.catalogue import CATALOGUE
    from solver.scene import Problem, SceneError, load_scene

    problems = [Problem(f"--set {f}", v, m) for f, v, m in bool_problems(overrides)]
    if scene_ref not in CATALOGUE and Path(scene_ref).is_file():
        try:
            data = load_yaml(Path(scene_ref).read_bytes(), f"SCENE = {scene_ref!r}")
        except (YamlError, OSError) as exc:
            raise UsageError(str(exc)) from None
        if isinstance(data, dict):
            problems += [Problem(f, v, m) for f, v, m in bool_problems({k: v for k, v in data.items() if k != "base"})]
    if problems:
        raise SceneError(problems)
    scene = load_scene(scene_ref, overrides)
    if budget:
        from solver.budget import check

        too_large = check(scene)
        if too_large:
            raise SceneError([Problem(f, v, m) for f, v, m in too_large])
    return scene


# ------------------------------------------------------------------ scenes
def cmd_scenes(args) -> int:
    from solver.catalogue import CATALOGUE

    if args.json:
        from solver.scene import load_scene

        _print_json([{"name": n, "description": d, "fidelity": load_scene(n).fidelity} for n, (_, d) in CATALOGUE.items()])
        return EXIT_OK
    width = max(len(n) for n in CATALOGUE)
    for name, (_, desc) in CATALOGUE.items():
        print(f"{name:<{width}}  {desc}")
    return EXIT_OK


# ------------------------------------------------------------------ run
def _progress_printer(enabled: bool):
    if not enabled:
        return None

    def progress(fraction: float, message: str = "") -> bool:
        bar = "#" * int(30 * fraction)
        print(f"\r[{bar:<30}] {100 * fraction:5.1f}% {message[:60]:<60}", end="", file=sys.stderr, flush=True)
        if fraction >= 1.0:
            print(file=sys.stderr)
        return True

    return progress


def cmd_run(args) -> int:
    from solver import run

    scene = _load(args.scene, args.set)
    result = run(scene, progress=_progress_printer(sys.stderr.isatty() and not args.quiet))
    if args.output:
        result.write_hdf5(args.output)
    summary = result.summary()
    if args.json:
        _print_json(summary)
    else:
        _print_summary(summary)
        if args.output:
            print(f"result written to {args.output}")
    return {"ok": EXIT_OK, "unstable": EXIT_UNSTABLE}.get(result.status, EXIT_FAILED)


def _print_summary(summary: dict) -> None:
    keys = ["scene", "fidelity", "status", "cutting_force_N_per_mm", "thrust_force_N_per_mm", "damage_depth_um",
            "bounce_back_um", "energy_error", "wall_time_s", "steps"]
    rest = [k for k in summary if k not in keys and k not in ("warnings", "diagnosis")]
    width = max(len(k) for k in keys + rest)
    for k in keys + rest:
        v = summary.get(k)
        if isinstance(v, float):
            v = f"{v:.6g}"
        elif isinstance(v, (dict, list)):
            v = json.dumps(v, default=str)
        print(f"{k:<{width}}  {v}")
    for w in summary.get("warnings") or []:
        print(f"warning: {w}")
    if summary.get("diagnosis"):
        d = {k: v for k, v in summary["diagnosis"].items() if k != "traceback"}
        print("diagnosis: " + json.dumps(d, default=str))


# ------------------------------------------------------------------ verify
def cmd_verify(args) -> int:
    from solver.scene import parse_set_options
    from solver.verification import load_cases

    cases = load_cases()
    if args.case and args.case not in cases:
        raise UsageError(f"case = {args.case!r}: unknown verification case; allowed: {', '.join(cases) or '(none available)'}")
    overrides = parse_set_options(args.set or [])
    names = [args.case] if args.case else list(cases)
    rows = []
    for name in names:
        fn, _ = cases[name]
        try:
            rows.append(fn(dict(overrides)).as_dict())
        except (TypeError, ValueError, KeyError) as exc:
            if args.case:
                raise UsageError(f"--set: {exc}") from None
            rows.append({"case": name, "passed": False, "error": None, "failure": f"{type(exc).__name__}: {exc}"})
    if args.json:
        _print_json(rows)
    else:
        print(f"{'case':<28} {'quantity':<34} {'value':>12} {'reference':>12} {'error':>9} {'tol':>7} {'wall s':>8}  result")
        for r in rows:
            if r.get("error") is None:
                print(f"{r['case']:<28} {'':<34} {'':>12} {'':>12} {'':>9} {'':>7} {'':>8}  FAILED {r.get('failure', '')}")
                continue
            print(f"{r['case']:<28} {r['quantity'][:34]:<34} {r['value']:>12.5g} {r['reference']:>12.5g} "
                  f"{r['error']:>9.2e} {r['tolerance']:>7.1e} {r['wall_time_s']:>8.2f}  {'pass' if r['passed'] else 'FAIL'}")
            if not r["passed"] and r.get("details", {}).get("finding"):
                print(f"    {r['details']['finding']}")  # what a case found when it could not measure its quantity
    return EXIT_OK if all(r.get("passed") for r in rows) else EXIT_FAILED


# ------------------------------------------------------------------ bench
def _int_list(text: str) -> list[int]:
    try:
        values = [int(float(x)) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of integers") from None
    if not values or any(v < 1 for v in values):
        raise argparse.ArgumentTypeError(f"{text!r}: every value must be a positive integer")
    return values


def cmd_bench(args) -> int:
    from solver import bench

    names = bench.available()
    if args.name not in names:
        raise UsageError(f"name = {args.name!r}: unknown benchmark; allowed: {', '.join(names) or '(none available)'}")
    kwargs = {"threads": args.threads}
    if args.dim != 2:
        if args.name not in ("fem", "sph"):
            raise UsageError(f"--dim = {args.dim}: only the fem and sph benchmarks have a 3D workload")
        kwargs["dim"] = args.dim
    if args.sizes:
        kwargs["sizes"] = args.sizes
    rows = bench.get(args.name)(**kwargs)
    if args.json:
        _print_json(rows)
    else:
        keys = list(rows[0]) if rows else []
        print("  ".join(f"{k:>14}" for k in keys))
        for r in rows:
            print("  ".join(f"{r[k]:>14.4g}" if isinstance(r[k], float) else f"{r[k]!s:>14}" for k in keys))
    return EXIT_OK


# ------------------------------------------------------------------ plots
def cmd_plot(args) -> int:
    from pathlib import Path

    from solver.plots import plot_result

    import h5py

    what = f"RESULT = {args.result!r}"
    if not Path(args.result).is_file():
        raise UsageError(f"{what}: no such file; give an HDF5 file written by 'fibrecut run -o'")
    try:
        hdf5 = h5py.is_hdf5(args.result)
    except OSError as exc:
        raise UsageError(f"{what}: cannot be read ({exc})") from None
    if not hdf5:
        raise UsageError(f"{what}: not an HDF5 file; give a file written by 'fibrecut run -o' or GET /api/runs/ID/result.h5")
    try:
        paths = plot_result(args.result, args.output or str(Path(args.result).with_suffix("")))
    except (KeyError, OSError, ValueError, TypeError) as exc:
        raise UsageError(f"{what}: not a fibrecut result file ({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}); "
                         "give a file written by 'fibrecut run -o'") from None
    for path in paths:
        print(path)
    return EXIT_OK


def cmd_plot_mesh(args) -> int:
    from solver.plots import plot_mesh

    scene = _load(args.scene, args.set)
    print(plot_mesh(scene, args.output))
    return EXIT_OK


# ------------------------------------------------------------------ parser
def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="fibrecut", description="Simulate and optimise orthogonal cutting of CFRP.")
    # the study commands' client options work before the command too (fibrecut --url X status)
    p.add_argument("--url", help="service URL for submit/status/results/cancel (default $FIBRECUT_URL or http://127.0.0.1:8000)")
    p.add_argument("--token", help="API token (default $FIBRECUT_API_TOKEN)")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    s = sub.add_parser("scenes", help="list the built-in scenes")
    s.add_argument("--json", action="store_true")
    s.set_defaults(func=cmd_scenes)

    s = sub.add_parser("run", help="run one scene and print its summary")
    s.add_argument("scene", metavar="SCENE", help="built-in scene name or a YAML/JSON scene file")
    s.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a field by dotted name (repeatable)")
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.add_argument("-o", "--output", metavar="FILE.h5", help="write the run's HDF5 file")
    s.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    s.set_defaults(func=cmd_run)

    s = sub.add_parser("verify", help="verification cases: error against analytic references and run time")
    s.add_argument("case", nargs="?", metavar="CASE")
    s.add_argument("--set", action="append", metavar="NAME=VALUE")
    s.add_argument("--json", action="store_true")
    s.set_defaults(func=cmd_verify)

    s = sub.add_parser("bench", help="benchmarks: element or particle updates per second")
    s.add_argument("name", metavar="NAME", help="fem, sph or analytic")
    s.add_argument("--threads", type=_int_list, default=[1, 2], help="comma-separated thread counts (default 1,2)")
    s.add_argument("--sizes", type=_int_list, help="comma-separated problem sizes")
    s.add_argument("--dim", type=int, choices=(2, 3), default=2,
                   help="fem and sph: 2 (plane strain, default) or 3 (hexahedra; 3D particles)")
    s.add_argument("--json", action="store_true")
    s.set_defaults(func=cmd_bench)

    s = sub.add_parser("plot", help="render a result's force history and chip frames as PNG")
    s.add_argument("result", metavar="RESULT.h5")
    s.add_argument("-o", "--output", metavar="PREFIX", help="output file prefix (default: next to the result)")
    s.set_defaults(func=cmd_plot)

    s = sub.add_parser("plot-mesh", help="draw a scene's mesh as PNG")
    s.add_argument("scene", metavar="SCENE")
    s.add_argument("--set", action="append", metavar="NAME=VALUE")
    s.add_argument("-o", "--output", metavar="FILE.png", default="mesh.png")
    s.set_defaults(func=cmd_plot_mesh)

    for mod in ("cli.study", "cli.analysis"):
        try:
            module = __import__(mod, fromlist=["register"])
        except ModuleNotFoundError as exc:
            if exc.name != mod:
                raise
            continue
        module.register(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    from solver.scene import SceneError

    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except SceneError as exc:
        print(f"fibrecut: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except UsageError as exc:
        print(f"fibrecut: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("fibrecut: interrupted", file=sys.stderr)
        return 130
    except SystemExit:
        raise
    except Exception as exc:  # noqa: BLE001 - one line, not a traceback (FIBRECUT_DEBUG=1 shows it)
        import os

        if os.environ.get("FIBRECUT_DEBUG"):
            raise
        from sqlalchemy.exc import OperationalError

        if isinstance(exc, OperationalError):
            print(f"fibrecut: error: the database is not reachable: {str(exc.orig).splitlines()[0] if exc.orig else exc}",
                  file=sys.stderr)
        else:
            print(f"fibrecut: error: {type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''} "
                  "(FIBRECUT_DEBUG=1 shows the traceback)", file=sys.stderr)
        return EXIT_FAILED


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
