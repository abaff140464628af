"""A LunarSim process starts NumPy's BLAS with one thread, unless its environment asks for more."""

from __future__ import annotations

import os
import subprocess
import sys

from bus.process import BLAS_THREAD_VARIABLES

THREADS = "print(open('/proc/self/status').read().split('Threads:')[1].split()[0])"


def _run(code: str, **env: str) -> str:
    clean = {k: v for k, v in os.environ.items() if k not in BLAS_THREAD_VARIABLES}
    done = subprocess.run([sys.executable, "-c", code], env={**clean, **env}, capture_output=True, text=True,
                          timeout=60, check=True)
    return done.stdout.split()[-1]


def test_numpy_imported_after_it_starts_no_blas_thread():
    assert _run(f"from bus import process; process.one_blas_thread(); import numpy; {THREADS}") == "1"


def test_a_thread_count_the_user_set_is_kept():
    code = "import os; from bus import process; process.one_blas_thread(); print(os.environ['OPENBLAS_NUM_THREADS'])"
    assert _run(code, OPENBLAS_NUM_THREADS="4") == "4"


def test_the_lunarsim_command_sets_it_in_the_environment_its_processes_inherit():
    code = ("import os, sys; from deploy import cli; sys.stderr = open(os.devnull, 'w'); "
            "cli.main(['scenario', 'check', '/nonexistent.yaml']); print(os.environ['OPENBLAS_NUM_THREADS'])")
    assert _run(code) == "1"
