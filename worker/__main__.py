"""``python -m worker --db URL --data DIR``: one worker process (what ``fibrecut worker`` runs)."""

import argparse
import os
import sys

from .worker import main

if __name__ == "__main__":
    p = argparse.ArgumentParser(prog="python -m worker")
    p.add_argument("--db", default=os.environ.get("FIBRECUT_DB"))
    p.add_argument("--data", default=os.environ.get("FIBRECUT_DATA", "fibrecut-data"))
    p.add_argument("--lease", type=float, default=float(os.environ.get("FIBRECUT_LEASE_S", "30")))
    p.add_argument("--isolation", choices=("auto", "inline", "process"), default="auto")
    p.add_argument("--max-jobs", type=int)
    p.add_argument("--exit-when-idle", action="store_true")
    p.add_argument("--exit-with-parent", action="store_true", help="stop when the process that started this one ends")
    a = p.parse_args()
    if not a.db:
        from store.config import sqlite_url

        a.db = sqlite_url(a.data)
    sys.exit(main(a.db, a.data, a.lease, a.isolation, a.max_jobs, a.exit_when_idle,
                  parent_pid=os.getppid() if a.exit_with_parent else None))
