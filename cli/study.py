"""Study commands of ``fibrecut``: serve, worker, submit, status, results, cancel.

``register(subparsers)`` adds them to the lead's parser (cli/main.py); each handler
returns an exit code. Bad input exits 2 with one line naming the field, the value and
what is allowed; an unreachable service or a failed study exits 1.
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2


def _usage(msg: str):
    from cli.main import UsageError

    return UsageError(msg)


def _client(args):
    from cli.client import Client

    return Client(getattr(args, "url", None), getattr(args, "token", None))


def _api(fn):
    """Map API errors: 4xx input errors exit 2 with the server's one-line reason, others 1."""
    from cli.client import ApiError

    try:
        return fn()
    except ApiError as exc:
        if exc.status in (400, 404, 413, 422):
            raise _usage(str(exc)) from None
        print(f"fibrecut: error: {exc}" if exc.status == 0 else f"fibrecut: error: HTTP {exc.status}: {exc}", file=sys.stderr)
        raise SystemExit(EXIT_FAILED) from None


# ------------------------------------------------------------------ serve / worker
def check_db_url(url: str | None, option: str = "--db") -> None:
    """A usage error (exit 2) for a URL SQLAlchemy cannot parse or a driver that is not installed."""
    if not url:
        return
    import sqlalchemy as sa
    from sqlalchemy.exc import ArgumentError, NoSuchModuleError

    allowed = "allowed: sqlite:///PATH or postgresql+psycopg://USER@HOST/DB"
    try:
        dialect = sa.engine.make_url(url).get_dialect()
    except (ArgumentError, NoSuchModuleError, ValueError) as exc:
        raise _usage(f"{option} = {_redact(url)!r}: not a database URL ({str(exc).splitlines()[0]}); {allowed}") from None
    try:
        dialect.import_dbapi()
    except ImportError as exc:
        hint = " (pip install 'fibrecut[postgres]', or run scripts/serve.sh, which installs it)" if "psycopg" in str(exc) else ""
        raise _usage(f"{option} = {_redact(url)!r}: its driver is not installed: {exc}{hint}") from None


def _redact(url: str) -> str:
    try:
        import sqlalchemy as sa

        return sa.engine.make_url(url).render_as_string(hide_password=True)
    except Exception:  # noqa: BLE001
        return url


def cmd_serve(args) -> int:
    from service.server import serve

    check_db_url(args.db)
    return serve(host=args.host, port=args.port, data_dir=args.data, db_url=args.db, workers=args.workers)


def cmd_worker(args) -> int:
    from worker.worker import main

    db = args.db
    check_db_url(db)
    if not db:
        from store.config import sqlite_url

        db = sqlite_url(args.data)
    return main(db, args.data, lease_s=args.lease)


# ------------------------------------------------------------------ submit
def _load_document(path: str) -> dict:
    from service.inputs import YamlError, load_yaml

    p = Path(path)
    if not p.is_file():
        raise _usage(f"STUDY = {path!r}: no such file; give a study YAML/JSON file")
    try:
        doc = load_yaml(p.read_bytes(), f"STUDY = {path!r}")
    except (YamlError, OSError) as exc:
        raise _usage(str(exc)) from None
    if not isinstance(doc, dict):
        raise _usage(f"STUDY = {path!r}: must be a mapping with name, kind, scene, parameters, ...")
    if "measurements_file" in doc:  # a calibration's measured points as a CSV file, relative to the study file
        ref = doc.pop("measurements_file")
        f = p.parent / str(ref)
        if not isinstance(ref, str) or not f.is_file():
            raise _usage(f"measurements_file = {ref!r}: no such file (relative to {p.parent}); give the CSV of the measured points")
        try:
            doc["measurements_csv"] = f.read_text(encoding="utf-8")
        except UnicodeDecodeError as exc:
            raise _usage(f"measurements_file = {ref!r}: not UTF-8 text (byte {exc.start})") from None
    return doc


def _bar(study: dict) -> str:
    c = study["counts"]
    frac = study.get("progress") or 0.0
    eta = study.get("eta_s")
    eta_s = f" ETA {eta:5.0f} s" if eta is not None else ""
    return (f"\r[{'#' * int(30 * frac):<30}] {100 * frac:5.1f}% done {c['done']} failed {c['failed']} "
            f"running {c['running']} queued {c['queued']} cached {c['cached']}{eta_s}  ")


def cmd_submit(args) -> int:
    doc = _load_document(args.study)
    client = _client(args)
    study = _api(lambda: client.submit(doc))
    print(f"study {study['id']} ({study['name']}, {study['kind']}): {study['status']}, {study['planned_jobs']} jobs planned")
    if not args.wait:
        return EXIT_OK
    tty = sys.stderr.isatty()
    while study["status"] in ("queued", "running"):
        if tty:
            print(_bar(study), end="", file=sys.stderr, flush=True)
        time.sleep(args.poll)
        study = _api(lambda: client.study(study["id"]))
    if tty:
        print(_bar(study), file=sys.stderr)
    c = study["counts"]
    print(f"study {study['id']}: {study['status']} (done {c['done']}, failed {c['failed']}, cancelled {c['cancelled']}, cached {c['cached']})")
    return EXIT_OK if study["status"] == "done" else EXIT_FAILED


# ------------------------------------------------------------------ status / results / cancel
def cmd_status(args) -> int:
    client = _client(args)
    if args.id is None:
        rows = _api(client.studies)
        if args.json:
            print(json.dumps(rows, indent=2))
            return EXIT_OK
        print(f"{'id':>5}  {'name':<28} {'kind':<12} {'status':<10} {'done':>5} {'failed':>6} {'running':>7} {'queued':>6} {'progress':>8}")
        for s in rows:
            c = s["counts"]
            print(f"{s['id']:>5}  {s['name'][:28]:<28} {s['kind']:<12} {s['status']:<10} {c['done']:>5} {c['failed']:>6} "
                  f"{c['running']:>7} {c['queued']:>6} {100 * s['progress']:>7.1f}%")
        return EXIT_OK
    s = _api(lambda: client.study(args.id))
    if args.json:
        print(json.dumps(s, indent=2))
        return EXIT_OK
    c = s["counts"]
    print(f"study {s['id']}: {s['name']} ({s['kind']}) {s['status']}")
    print(f"  jobs: planned {s['planned_jobs']}, done {c['done']}, failed {c['failed']}, running {c['running']}, "
          f"queued {c['queued']}, cancelled {c['cancelled']}, cached {c['cached']}")
    print(f"  progress {100 * s['progress']:.1f}%" + (f", ETA {s['eta_s']:.0f} s" if s.get("eta_s") is not None else ""))
    from .study_text import summary_lines

    for line in summary_lines(s):
        print(line)
    if s.get("error"):
        print(f"  error: {s['error']}")
    return EXIT_OK


def cmd_results(args) -> int:
    client = _client(args)
    if args.csv:
        sys.stdout.write(_api(lambda: client.trials_csv(args.id)))
        return EXIT_OK
    rows = _api(lambda: client.trials(args.id))
    if args.json:
        print(json.dumps(rows, indent=2))
        return EXIT_OK
    params = sorted({k for r in rows for k in r["params"]})
    metrics = ["cutting_force_N_per_mm", "thrust_force_N_per_mm", "damage_depth_um", "wall_time_s"]
    head = ["#", "status", *params, *metrics, "run"]
    print("  ".join(f"{h:>14}" for h in head))
    for r in rows:
        m = r["metrics"] or {}
        cells = [str(r["index"]), r["status"] + ("*" if r["cached"] else ""), *[_fmt(r["params"].get(p)) for p in params],
                 *[_fmt(m.get(k)) for k in metrics], (r["run_id"] or "-")[:12]]
        print("  ".join(f"{c:>14}" for c in cells))
    if any(r["cached"] for r in rows):
        print("(* cached: the run was reused from an identical scene)")
    _print_levels(rows)
    return EXIT_OK


def _print_levels(rows: list[dict]) -> None:
    """A convergence study with replicas: one line per level, the means with their standard errors
    and the error of each mean against the finest mean with its standard error."""
    levels = {}
    for r in rows:
        lv = r.get("level")
        if lv:
            levels.setdefault(json.dumps(lv["params"], sort_keys=True), r)
    if not levels:
        return
    print("\nlevels (mean +- standard error over the replicas whose run ended ok; error of the mean vs the finest mean +- its standard error):")
    for r in levels.values():
        lv = r["level"]
        name = ", ".join(f"{k.split('.')[-1]} = {_fmt(v)}" for k, v in lv["params"].items())
        parts = [f"{name}{' (finest)' if lv.get('is_finest') else ''}: {lv['replicas_ok']}/{lv['replicas']} ok, {_fmt(lv['wall_time_per_run_s'])} s per run"]
        for m, short in (("cutting_force_N_per_mm", "Fc"), ("thrust_force_N_per_mm", "Ft")):
            mean, sem = lv["mean"].get(m), lv["sem"].get(m)
            text = f"{short} {_fmt(mean)}" + (f" +- {sem:.2g}" if isinstance(sem, float) else "")
            err, unc = (r.get("error_vs_finest") or {}).get(m), (r.get("error_uncertainty") or {}).get(m)
            if not lv.get("is_finest") and isinstance(err, float):
                text += f" (error {100 * err:.3g} %" + (f" +- {100 * unc:.2g} %" if isinstance(unc, float) else "") + ")"
            parts.append(text)
        print("  " + "; ".join(parts))


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.5g}"
    return "-" if v is None else str(v)


def cmd_cancel(args) -> int:
    client = _client(args)
    s = _api(lambda: client.cancel(args.id))
    print(f"study {s['id']}: {s['status']} (running jobs stop at their next heartbeat)")
    return EXIT_OK


# ------------------------------------------------------------------ parser
def _int_type(noun: str, ok, allowed: str):
    """An argparse type: an integer that ``ok`` accepts; its errors name the text and what is allowed."""

    def parse(text: str) -> int:
        import argparse

        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {noun}") from None
        if not ok(v):
            raise argparse.ArgumentTypeError(f"{text!r}: {allowed}")
        return v

    return parse


_positive_int = _int_type("an integer", lambda v: v >= 1, "must be at least 1")
_port = _int_type("a port number", lambda v: 0 < v < 65536, "allowed 1 to 65535")


def register(subparsers) -> None:
    import argparse

    def client_opts(p):
        # SUPPRESS: not given here, the value given before the command (or None) stays
        p.add_argument("--url", default=argparse.SUPPRESS, help="service URL (default $FIBRECUT_URL or http://127.0.0.1:8000)")
        p.add_argument("--token", default=argparse.SUPPRESS, help="API token (default $FIBRECUT_API_TOKEN)")

    s = subparsers.add_parser("serve", help="the API, dashboard and a local worker pool")
    s.add_argument("--host", default="127.0.0.1", help="bind address (default 127.0.0.1: this machine only)")
    s.add_argument("--port", type=_port, default=8000)
    s.add_argument("--data", default=os.environ.get("FIBRECUT_DATA", "fibrecut-data"), help="data folder (default ./fibrecut-data)")
    s.add_argument("--db", default=os.environ.get("FIBRECUT_DB"), help="database URL (default: SQLite in the data folder)")
    s.add_argument("--workers", type=int, default=None, help="worker processes (default: one per core; 0 = none)")
    s.set_defaults(func=cmd_serve)

    s = subparsers.add_parser("worker", help="one more worker on any machine")
    s.add_argument("--db", default=os.environ.get("FIBRECUT_DB"), help="database URL (e.g. postgresql+psycopg://user@host/db)")
    s.add_argument("--data", default=os.environ.get("FIBRECUT_DATA", "fibrecut-data"), help="data folder (shared with the API)")
    s.add_argument("--lease", type=float, default=float(os.environ.get("FIBRECUT_LEASE_S", "30")), help="lease seconds")
    s.set_defaults(func=cmd_worker)

    s = subparsers.add_parser("submit", help="submit a study (YAML/JSON) to the service")
    s.add_argument("study", metavar="STUDY.yaml")
    s.add_argument("--wait", action="store_true", help="wait for the study to end, with a progress bar")
    s.add_argument("--poll", type=float, default=1.0, help=argparse_suppress())
    client_opts(s)
    s.set_defaults(func=cmd_submit)

    s = subparsers.add_parser("status", help="all studies, or one study's state")
    s.add_argument("id", nargs="?", type=_positive_int, metavar="ID")
    s.add_argument("--json", action="store_true")
    client_opts(s)
    s.set_defaults(func=cmd_status)

    s = subparsers.add_parser("results", help="a study's trials: parameters, metrics, run ids")
    s.add_argument("id", type=_positive_int, metavar="ID")
    s.add_argument("--csv", action="store_true", help="CSV on stdout")
    s.add_argument("--json", action="store_true")
    client_opts(s)
    s.set_defaults(func=cmd_results)

    s = subparsers.add_parser("cancel", help="cancel a study (queued jobs at once, running ones at their next heartbeat)")
    s.add_argument("id", type=_positive_int, metavar="ID")
    client_opts(s)
    s.set_defaults(func=cmd_cancel)


def argparse_suppress():
    import argparse

    return argparse.SUPPRESS
