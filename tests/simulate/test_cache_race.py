"""The race into the compiled-code cache, run for real between two accounts
(docs/stages/simulate.md, "The compiled-step cache"): the victim, a uid without privileges,
uses a cache folder in a shared sticky folder (as the ``$TMPDIR/dmoc-<uid>`` fallback),
and stops before every file operation of the cache (`os` in its modules replaced by a
wrapper that waits) while an attacker, another uid, swaps a link at that path between a
folder of the victim's own and a folder of its own holding a library under the name the
victim looks for, whose constructor writes a marker file. For every window (the attack
starting at operation k, for every k up to the last), the victim either loads its own
code or refuses with a `CompiledCodeError`; the attacker's code never runs."""

import json
import os
import shutil
import subprocess
import sys
import tempfile

import casadi as ca
import pytest

from dmoc._util import compiled

pytestmark = pytest.mark.skipif(compiled.compiler() is None, reason="no C compiler")

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
VICTIM, ATTACKER = 54321, 54322         # two uids without passwd entries
ROUNDS = 30                             # of the random attack

VICTIM_CODE = """
import json, os, shutil, sys
import casadi as ca
import numpy as np
from dmoc._util import cache_folder, compiled, private_folder, sealed_file
from dmoc.errors import CompiledCodeError

to_attacker = os.fdopen(int(sys.argv[1]), "wb", buffering=0)
from_attacker = os.fdopen(int(sys.argv[2]), "rb", buffering=0)
path, decoy, mode = sys.argv[3], sys.argv[4], sys.argv[5]
count = [0]

def talk(message):
    to_attacker.write(message + b"\\n")
    assert from_attacker.readline() == b"k\\n"

class Waiting:
    '''os, each function waiting for the attacker's move before it runs.'''
    def __getattr__(self, name):
        real = getattr(os, name)
        if not callable(real) or isinstance(real, type):
            return real
        def waiting(*args, **kwargs):
            count[0] += 1
            talk(b"h")
            return real(*args, **kwargs)
        return waiting

for module in (private_folder, cache_folder, compiled, sealed_file):
    module.os = Waiting()
x = ca.SX.sym("x", 2)
library = compiled.Library([ca.Function("f", [x], [2 * x])], "race")
os.setgroups([]); os.setgid({uid}); os.setuid({uid})
outcomes, k = [], 0
while True:
    if os.path.isdir(path) and not os.path.islink(path):
        shutil.rmtree(path)               # the victim's own folder of the last round
    for name in os.listdir(decoy) if mode != "random" else ():   # random: keep the library
        os.unlink(os.path.join(decoy, name)) if not os.path.isdir(os.path.join(decoy, name)) \\
            else shutil.rmtree(os.path.join(decoy, name))
    talk(b"r%d %s" % (k, mode.encode()))
    count[0] = 0
    try:
        f = library.load()["f"]
        values = np.array(f([1.0, 2.0])).ravel().tolist()
        outcomes.append("loaded" if values == [2.0, 4.0] else f"wrong {{values}}")
    except CompiledCodeError as err:
        outcomes.append("refused: " + str(err))
    if (count[0] <= k) if mode != "random" else k == {rounds}:
        break
    k += 1
talk(b"q")
print(json.dumps(outcomes))
"""

ATTACKER_CODE = """
import os, random, sys
os.setgroups([]); os.setgid({uid}); os.setuid({uid})
requests = os.fdopen(int(sys.argv[1]), "rb", buffering=0)
replies = os.fdopen(int(sys.argv[2]), "wb", buffering=0)
path, decoy, evil, name, good, plant = sys.argv[3:9]
contents = [open(good, "rb").read(), open(plant, "rb").read()]

def rewrite(data):
    '''Put `data` under the victim's library name in the attacker's folder.'''
    with open(os.path.join(evil, ".new"), "wb") as file:
        file.write(data)
    os.replace(os.path.join(evil, ".new"), os.path.join(evil, name))

def point(target):
    '''Make `path` a link to `target` (nothing when it is the victim's folder).'''
    if os.path.islink(path):
        os.unlink(path)
    if target is not None and not os.path.lexists(path):
        os.symlink(target, path)

k, mode, i = 0, "early", 0
while True:
    line = requests.readline().strip()
    if not line or line == b"q":
        replies.write(b"k\\n")
        break
    if line.startswith(b"r"):
        k, mode, i = int(line[1:].split()[0]), line.split()[1].decode(), 0
        rng = random.Random(k)
        point(decoy if mode == "early" else None)
    elif mode == "random":
        rewrite(rng.choice(contents))
        point(rng.choice([None, decoy, evil]))
    else:
        point(evil if i >= k else decoy if mode == "early" else None)
        i += 1
    replies.write(b"k\\n")
"""


@pytest.fixture
def arena(tmp_path):
    """(the shared sticky folder, the victim's cache path in it, a private folder of the
    victim's, the attacker's folder holding the plant under the victim's library name, the
    marker the plant writes)."""
    shared = tempfile.mkdtemp(prefix="race-")
    os.chmod(shared, 0o1777)
    decoy, evil = os.path.join(shared, "decoy"), os.path.join(shared, "evil")
    os.mkdir(decoy, 0o700)
    os.chown(decoy, VICTIM, VICTIM)
    os.mkdir(evil, 0o755)
    marker = os.path.join(shared, "marker")
    source = tmp_path / "plant.c"
    source.write_text('#include <stdio.h>\n__attribute__((constructor)) static void plant(void)'
                      f' {{ FILE *f = fopen("{marker}", "w"); if (f) fclose(f); }}\n')
    with pytest.MonkeyPatch.context() as patch:       # the victim's library, made here
        patch.setenv("DMOC_CACHE_DIR", str(tmp_path / "scratch"))
        x = ca.SX.sym("x", 2)
        compiled.Library([ca.Function("f", [x], [2 * x])], "race").load()
    (good,) = (tmp_path / "scratch").glob("race-*.so")
    plant = tmp_path / "plant.so"
    subprocess.run([compiled.compiler(), "-shared", "-fPIC", str(source), "-o", str(plant)],
                   check=True)
    lures = [good.name, str(shared_copy(good, shared)), str(shared_copy(plant, shared))]
    shutil.copy(plant, os.path.join(evil, good.name))      # the plant under the victim's name
    for name in (evil, *(os.path.join(evil, n) for n in os.listdir(evil))):
        os.chown(name, ATTACKER, ATTACKER)
    yield shared, os.path.join(shared, f"dmoc-{VICTIM}"), decoy, evil, marker, lures
    subprocess.run(["rm", "-rf", shared], check=True)


def shared_copy(path, shared):
    """A copy of file `path` in the folder `shared` that the attacker can read."""
    copy = os.path.join(shared, os.path.basename(path) + ".copy")
    shutil.copy(path, copy)
    os.chmod(copy, 0o644)
    return copy


def readable_by_others(path):
    """True when every folder above `path` lets others through and `path` lets them read."""
    path = os.path.abspath(path)
    while path != os.path.dirname(path):
        if not os.stat(path).st_mode & 0o005:
            return False
        path = os.path.dirname(path)
    return True


@pytest.mark.parametrize("mode", ["early", "late", "random"])
def test_an_account_swapping_links_in_every_window_never_runs_its_code(arena, mode):
    """early: the path is the attacker's link to the victim's own private folder from the
    start (the check passes with it), swapped to the attacker's folder from operation k on;
    late: no link until operation k, then one to the attacker's folder; random: at every
    operation of ROUNDS rounds, the link removed or pointed at either folder at random, and
    the attacker's file under the victim's library name rewritten with the victim's own
    library or the plant at random (what passes a hash may be swapped before a load)."""
    if os.geteuid() != 0:
        pytest.skip("two accounts need root to set the victim's and the attacker's uids")
    if not readable_by_others(os.path.join(os.path.dirname(ca.__file__), "include")):
        pytest.skip("another uid cannot read the installed CasADi package")
    shared, path, decoy, evil, marker, lures = arena
    to_attacker, to_victim = os.pipe(), os.pipe()
    env = {**os.environ, "PYTHONPATH": ROOT, "DMOC_CACHE_DIR": path}
    attacker = subprocess.Popen(
        [sys.executable, "-c", ATTACKER_CODE.format(uid=ATTACKER), str(to_attacker[0]),
         str(to_victim[1]), path, decoy, evil, *lures], pass_fds=(to_attacker[0], to_victim[1]),
        cwd=shared)
    os.close(to_attacker[0]), os.close(to_victim[1])      # a dead attacker: the victim sees EOF
    victim = subprocess.run(
        [sys.executable, "-c", VICTIM_CODE.format(uid=VICTIM, rounds=ROUNDS), str(to_attacker[1]),
         str(to_victim[0]), path, decoy, mode], pass_fds=(to_attacker[1], to_victim[0]),
        env=env, cwd=shared, capture_output=True, text=True, timeout=600)
    os.close(to_attacker[1]), os.close(to_victim[0])
    attacker.wait(timeout=60)
    assert victim.returncode == 0, victim.stderr
    outcomes = json.loads(victim.stdout)
    assert not os.path.exists(marker)
    assert len(outcomes) > 10                     # one round per window, and a last quiet one
    assert all(o == "loaded" or o.startswith("refused: ") for o in outcomes), outcomes
    if mode != "random":
        assert outcomes[-1] == "loaded"           # no attack at all: the victim's code runs
