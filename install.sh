#!/bin/sh
# Install acphys into a virtual environment, .venv, once: the README's two commands run this first.
#
# Does nothing when .venv already holds an install made the same way (compiled or not) from the same
# pyproject.toml and setup.py, so the test command only runs pytest from the second time on. The first
# time it says what it does and about how long it takes: pip prints little while it compiles.
#   ACPHYS_COMPILE=0 sh install.sh   the pure-Python engine: no C compiler, seconds instead of minutes,
#                                    engine edits take effect at once (the compiled modules would shadow them);
#                                    later runs without ACPHYS_COMPILE keep it (ACPHYS_COMPILE=1 compiles again)
#   ACPHYS_VENV=DIR                  another place for the virtual environment
set -eu
cd "$(dirname "$0")"
venv=${ACPHYS_VENV:-.venv}
stamp="$venv/.acphys-installed"
# ACPHYS_COMPILE unset: keep the way the last install was made (compiled unless told otherwise)
previous=$(sed -n 's/^compile=//p' "$stamp" 2>/dev/null || true)
compile=${ACPHYS_COMPILE:-${previous:-1}}

if [ -f "$stamp" ] && [ "$stamp" -nt pyproject.toml ] && [ "$stamp" -nt setup.py ] \
        && [ "$(cat "$stamp")" = "compile=$compile" ]; then
    exit 0
fi
if [ ! -x "$venv/bin/python" ]; then
    echo "acphys: creating the virtual environment $venv (python3 -m venv)" >&2
    if ! python3 -m venv "$venv"; then
        echo "acphys: python3 -m venv failed; on Debian or Ubuntu install the venv module first:" \
             "apt-get install python3-venv" >&2
        exit 1
    fi
fi
if [ "$compile" != 0 ]; then
    if ! command -v cc >/dev/null 2>&1 || ! "$venv/bin/python" -c 'import os, sys, sysconfig
sys.exit(not os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")))'; then
        echo "acphys: no C compiler or no Python headers (Debian: apt-get install gcc python3-dev):" \
             "installing the pure-Python engine (the same answers, 6 to 12 times slower)" >&2
        compile=0
    fi
fi
if [ "$compile" != 0 ]; then
    echo "acphys: installing into $venv and compiling the engine's hot modules with mypyc:" \
         "about 2 minutes on an idle 2-core machine (more while it is busy), with little output meanwhile" \
         "(ACPHYS_COMPILE=0 sh install.sh skips the compile)" >&2
else
    echo "acphys: installing into $venv with the pure-Python engine (no compile; under a minute)" >&2
fi
rm -f "$stamp"
ACPHYS_COMPILE=$compile "$venv/bin/python" -m pip install --disable-pip-version-check -e '.[test,demo,view]'
echo "compile=$compile" > "$stamp"
echo "acphys: installed. Commands: $venv/bin/acphys ... (or run '. $venv/bin/activate' once, then acphys ...)" >&2
