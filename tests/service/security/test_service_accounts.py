"""Accounts (`acphys serve --users FILE`): each user reaches its own movers only, by Zenoh's own
authentication (usrpwd) and access control (service/security/accounts.py).

One service with two users, alice and bob, over the demo world. Bob's own client and a raw Zenoh
session logged in as bob try every way into alice's movers: her ids on his keys, her keys, wildcards,
her push key, her state keys; none reaches her movers, and her next move's seq shows nothing moved
them. Sessions without the right password reach nothing at all. The movers still share one world:
bob's mover cannot walk through alice's.
"""

from __future__ import annotations

import math
import signal
from dataclasses import replace
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import msgpack
import pytest
import zenoh

from clients import Client, ServiceError
from clients.demo.world import global_to_cell
from engine.geometry import Position
from service.security.accounts import Accounts, AccountsError
from service.bus.zconfig import make_config
from support.cluster_files import cluster_file, make_certificates, tls_endpoint
from support.service_harness import ROOT, ServiceProcess, child_env, demo_world, free_port, human, start_on_ground, wait_until

USERS = {"alice": "wonder-land-7", "bob": "builder-42"}
RADIUS = 0.48  # human()'s spheres (tests/support/service_harness.py)


@pytest.fixture(scope="module")
def users_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("accounts") / "users.txt"
    path.write_text("".join(f"{u}:{p}\n" for u, p in USERS.items()), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def service(users_file: Path) -> Iterator[ServiceProcess]:
    with ServiceProcess(extra=["--users", str(users_file)]) as svc:
        yield svc


def _client(svc: ServiceProcess, user: str, password: str | None = None) -> Client:
    return Client([svc.endpoint], user=user, password=password or USERS[user], timeout=5.0)


def _session(svc: ServiceProcess, user: str | None, password: str | None = None) -> zenoh.Session:
    if user is None:
        return zenoh.open(make_config(connect=[svc.endpoint]))
    return zenoh.open(make_config(connect=[svc.endpoint], user=user, password=password or USERS[user]))


def _replies(session: zenoh.Session, key: str, content: dict[str, Any], timeout: float = 2.0) -> list[Any]:
    return list(session.get(key, payload=msgpack.packb({"v": 1, **content}), timeout=timeout))


def _ground(gx: float, gy: float = 100.0) -> Position:
    cell, x, y = global_to_cell(gx, gy)
    return start_on_ground(demo_world(), cell, x, y)


def _walk_east_across(alice: Client, mover_id: int) -> None:
    """Alice's mover from the west landblock A9B4 into AAB4 in 12 one-metre moves, each answered in seq order."""
    start = alice.register(human(), _ground(186.0), mover_id=mover_id)
    states = [alice.move(mover_id, offset=(1.0, 0.0, 0.0)) for _ in range(12)]
    assert [s.seq for s in states] == list(range(1, 13))
    assert start.landblock == 0xA9B4 and states[-1].landblock == 0xAAB4


def _out_of_reach(bob: Client, mover_id: int) -> None:
    """Bob's requests for the id, on either landblock's key of his space, find no mover."""
    for lb in (0xA9B4, 0xAAB4):
        bob.locate(mover_id, lb)
        with pytest.raises(ServiceError) as e:
            bob.get(mover_id)
        assert e.value.kind in ("unknown_mover", "moved", "wrong_landblock")


def _forged_handover(mover_id: int) -> dict[str, Any]:
    return {"id": mover_id, "seq": 1, "from": "bob", "mover": {"spheres": [[0, 0, 0.48, 0.48]]},
            "position": {"cell": (0xAAB4 << 16) | 1, "origin": [10.0, 10.0, 60.0], "orientation": [1.0, 0.0, 0.0, 0.0]}}


def test_a_users_ids_are_its_own(service: ServiceProcess) -> None:
    with _client(service, "alice") as alice, _client(service, "bob") as bob:
        mine = alice.register(human(), _ground(30.0), mover_id=0x700)
        alice.move(0x700, offset=(0.25, 0.0, 0.0))
        bob.locate(0x700, mine.landblock)
        for attempt in (lambda: bob.get(0x700), lambda: bob.move(0x700, offset=(5.0, 0.0, 0.0)),
                        lambda: bob.remove(0x700)):
            with pytest.raises(ServiceError) as e:
                attempt()
            assert e.value.kind == "unknown_mover"
        # the same id is free in bob's space: a mover of his own, elsewhere
        his = bob.register(human(), _ground(60.0), mover_id=0x700)
        assert his.id == 0x700 and his.seq == 0
        bob.move(0x700, offset=(0.5, 0.0, 0.0))
        bob.remove(0x700)
        state, _ = alice.get(0x700)
        assert state.seq == 1  # her one move; nothing of bob's touched it
        assert [i.data["movers"] for i in alice.health()] == [1]
        assert [i.data["movers"] for i in bob.health()] == [0]
        alice.remove(0x700)


def test_another_users_keys_answer_nothing(service: ServiceProcess) -> None:
    with _client(service, "alice") as alice:
        mine = alice.register(human(), _ground(35.0), mover_id=0x701)
        lb = f"{mine.landblock:04X}"
        bob = _session(service, "bob")
        try:
            for key in (f"acphys/u/alice/lb/{lb}/get", f"acphys/u/alice/lb/{lb}/remove", "acphys/u/alice/lb/*/get",
                        f"acphys/u/*/lb/{lb}/get", f"acphys/lb/{lb}/get", "acphys/**", "**"):
                assert _replies(bob, key, {"id": 0x701}) == [], key
            # his own space answers him, so the silence above is the access control, not a dead link
            answers = _replies(bob, f"acphys/u/bob/lb/{lb}/get", {"id": 0x701})
            assert len(answers) == 1 and answers[0].err is not None
            assert msgpack.unpackb(answers[0].err.payload.to_bytes())["error"]["kind"] == "unknown_mover"
            # fire-and-forget into her push key, directly and by wildcard
            push = {"v": 1, "move": {"id": 0x701, "offset": [3.0, 0.0, 0.0]}}
            for key in (f"acphys/u/alice/lb/{lb}/push", "acphys/u/*/lb/*/push", f"acphys/lb/{lb}/push"):
                bob.put(key, msgpack.packb(push))
            # and bob's own push of her id, which the service does take (then refuses: not his mover)
            errors: list[Any] = []
            sub = bob.declare_subscriber("acphys/u/bob/obj/**", lambda s: errors.append(str(s.key_expr)))
            time.sleep(0.3)
            bob.put(f"acphys/u/bob/lb/{lb}/push", msgpack.packb(push))
            assert wait_until(lambda: bool(errors), timeout=5.0), "bob's own push got no error"
            sub.undeclare()
        finally:
            bob.close()
        assert errors == ["acphys/u/bob/obj/701/error"]
        assert alice.get(0x701)[0].seq == 0  # bob's puts came before this get on one link each: none moved it
        assert alice.move(0x701, offset=(0.25, 0.0, 0.0)).seq == 1
        alice.remove(0x701)


def test_states_reach_their_own_user_only(service: ServiceProcess) -> None:
    with _client(service, "alice") as alice:
        mine = alice.register(human(), _ground(45.0), mover_id=0x702)
        theirs: list[str] = []
        ours: list[int] = []
        lock = threading.Lock()
        bob = _session(service, "bob")
        try:
            def spy(sample: zenoh.Sample) -> None:
                with lock:
                    theirs.append(str(sample.key_expr))

            spies = [bob.declare_subscriber(k, spy) for k in ("**", "acphys/**", "acphys/u/alice/obj/*/state",
                                                              "acphys/u/*/obj/**", "acphys/u/bob/**")]
            sub = alice.subscribe(lambda st: ours.append(st.seq), mover_id=0x702)
            time.sleep(0.5)
            for _ in range(3):
                alice.move(0x702, offset=(0.2, 0.0, 0.0))
            assert wait_until(lambda: len(ours) >= 3, timeout=5.0), ours
            time.sleep(0.3)
            sub.close()
            for s in spies:
                s.undeclare()
        finally:
            bob.close()
        assert ours == [1, 2, 3]
        assert theirs == []
        assert mine.id == 0x702
        alice.remove(0x702)


def test_one_users_flood_leaves_the_others_served(users_file: Path) -> None:
    """With a queue of 4 per user, alice floods her push key with batches (of over 128 moves: always queued,
    never run in the callback) far faster than the engine runs them, so that they are refused (`busy`, on
    her movers' error keys); bob's moves sent meanwhile wait in his own lane, behind at most one of hers,
    and none is refused. (With one lane for both, his are refused too.)"""
    with ServiceProcess(extra=["--users", str(users_file), "--queue", "4"]) as svc:
        with _client(svc, "alice") as alice, _client(svc, "bob") as bob:
            ids = [alice.register(human(), _ground(20.0 + 2.0 * k), mover_id=0x800 + k).id for k in range(8)]
            bob.register(human(), _ground(100.0), mover_id=0x900)
            raw = _session(svc, "alice")
            refused: list[str] = []
            try:
                sub = raw.declare_subscriber("acphys/u/alice/obj/*/error", lambda s: refused.append(
                    msgpack.unpackb(s.payload.to_bytes())["error"]["kind"]))
                pub = raw.declare_publisher("acphys/u/alice/lb/A9B4/push",
                                            congestion_control=zenoh.CongestionControl.BLOCK)
                batch = msgpack.packb({"v": 1, "moves": [{"id": ids[k % len(ids)], "offset": [0.01, 0.0, 0.0]}
                                                         for k in range(200)]})
                time.sleep(0.3)
                done = threading.Event()

                def flood() -> None:
                    for _ in range(20_000):  # until bob is done (bounded)
                        if done.is_set():
                            return
                        pub.put(batch)
                        time.sleep(0.001)

                flooder = threading.Thread(target=flood)
                flooder.start()
                bob_kinds: list[str] = []
                seqs: list[int] = []
                try:
                    assert wait_until(lambda: "busy" in refused, timeout=30.0), refused[:5]
                    for _ in range(10):
                        try:
                            seqs.append(bob.move(0x900, offset=(0.05, 0.0, 0.0), timeout=30.0).seq)
                        except ServiceError as e:
                            bob_kinds.append(e.kind)
                finally:
                    done.set()
                    flooder.join(60)
                sub.undeclare()
                pub.undeclare()
            finally:
                raw.close()
            assert bob_kinds == []
            assert seqs == list(range(1, 11))


def test_without_the_right_password_there_is_no_service(service: ServiceProcess) -> None:
    for user, password in (("bob", "not-his"), ("alice", USERS["bob"]), ("mallory", "anything")):
        with Client([service.endpoint], user=user, password=password, timeout=1.0) as c:
            assert c.health() == []
    anonymous = _session(service, None)
    try:
        assert list(anonymous.get("acphys/**", timeout=1.0)) == []
        assert list(anonymous.get("acphys/u/alice/health", timeout=1.0)) == []
    finally:
        anonymous.close()
    with _client(service, "alice") as alice:  # and the right one does reach it
        assert [i.data["status"] for i in alice.health()] == ["ok"]


def test_users_share_one_world(service: ServiceProcess) -> None:
    """Bob's mover walks 4 m straight at alice's: the spheres cannot pass through each other (neither is a
    player: players pass through each other)."""
    solid = replace(human(), state=[])
    with _client(service, "alice") as alice, _client(service, "bob") as bob:
        hers = alice.register(solid, _ground(80.0), mover_id=0x703)
        his = bob.register(solid, _ground(78.0), mover_id=0x703)
        moved = bob.move(0x703, offset=(4.0, 0.0, 0.0))
        a, b = hers.position.origin, moved.position.origin
        apart = math.hypot(a.x - b.x, a.y - b.y)
        assert b.x < a.x and apart >= 2 * RADIUS - 0.02, (a, b)
        assert moved.position.origin.x > his.position.origin.x  # it did walk up to her
        assert not moved.result.collide_objects  # her mover is not named to him
        bob.remove(0x703)
        alice.remove(0x703)


def test_without_an_admin_nobody_changes_the_world(service: ServiceProcess) -> None:
    """A service run with `--users` and no `--admin`: every user's load and unload is `forbidden`, even of
    an empty landblock, and the landblock stays loaded for everyone."""
    with _client(service, "alice") as alice, _client(service, "bob") as bob:
        (before,) = alice.landblocks()
        assert 0xA9B4 in before.data["loaded"]
        for user in (alice, bob):
            for op in (user.unload_landblock, user.load_landblock):
                with pytest.raises(ServiceError) as e:
                    op(0xA9B4)
                assert e.value.kind == "forbidden" and "--admin" in str(e.value)
        assert [i.data["loaded"] for i in bob.landblocks()] == [before.data["loaded"]]
        assert alice.register(human(), _ground(186.0), mover_id=0x704).landblock == 0xA9B4  # still there
        alice.remove(0x704)


def test_an_admin_loads_and_unloads_for_everyone(users_file: Path) -> None:
    """`--admin alice`: bob's unload is `forbidden` whatever the landblock holds; alice's is refused while
    anyone's mover is inside (bob's counted, not named), then goes through, for every user; a scene's
    landblock cannot be loaded again (what the role keeps other users from doing)."""
    with ServiceProcess(extra=["--users", str(users_file), "--admin", "alice"]) as svc:
        with _client(svc, "alice") as alice, _client(svc, "bob") as bob:
            lb = 0xA9B4
            alice.register(human(), _ground(150.0), mover_id=0x706)
            bob.register(human(), _ground(170.0), mover_id=0x707)
            with pytest.raises(ServiceError) as e:
                bob.unload_landblock(lb)
            assert e.value.kind == "forbidden"
            with pytest.raises(ServiceError) as e:
                alice.unload_landblock(lb)
            assert e.value.kind == "landblock_in_use"
            assert "1 mover(s): 706" in str(e.value) and "1 mover(s) of other users" in str(e.value)
            assert "707" not in str(e.value) and e.value.details.get("movers") == [0x706]
            bob.remove(0x707)
            alice.remove(0x706)
            with pytest.raises(ServiceError) as e:
                bob.unload_landblock(lb)  # empty now: still not his to unload
            assert e.value.kind == "forbidden"
            assert lb in bob.landblocks()[0].data["loaded"]
            assert alice.load_landblock(lb) is True  # already loaded
            alice.unload_landblock(lb)
            assert lb not in bob.landblocks()[0].data["loaded"]
            with pytest.raises(ServiceError) as e:
                alice.load_landblock(lb)
            assert e.value.kind == "landblock_unavailable"


def test_the_command_line_logs_in(service: ServiceProcess, tmp_path: Path) -> None:
    secret = tmp_path / "alice.pw"
    secret.write_text(USERS["alice"] + "\n", encoding="utf-8")
    base = [sys.executable, "-m", "clients", "stats", "--connect", service.endpoint, "--timeout", "3", "--json"]
    by_file = subprocess.run([*base, "--user", "alice", "--password-file", str(secret)], cwd=ROOT, env=child_env(),
                             capture_output=True, text=True, timeout=60)
    assert by_file.returncode == 0, by_file.stderr
    env = {**child_env(), "ACPHYS_PASSWORD": USERS["bob"]}
    by_env = subprocess.run([*base, "--user", "bob"], cwd=ROOT, env=env, capture_output=True, text=True, timeout=60)
    assert by_env.returncode == 0, by_env.stderr
    no_password = {k: v for k, v in child_env().items() if k != "ACPHYS_PASSWORD"}
    missing = subprocess.run([*base, "--user", "bob"], cwd=ROOT, env=no_password, capture_output=True, text=True,
                             timeout=60)
    assert missing.returncode != 0 and "password" in missing.stderr


def test_the_demo_walks_in_a_users_space_without_loading(service: ServiceProcess, tmp_path: Path) -> None:
    """`acphys demo --user bob` on a service whose users may not load: the demo world is loaded already, so
    the walk runs on the running service, in bob's space, and asks for no load."""
    out = tmp_path / "walk.png"
    with _client(service, "bob") as bob:
        (before,) = bob.stats()
    env = {**child_env(), "ACPHYS_PASSWORD": USERS["bob"]}
    r = subprocess.run([sys.executable, "-m", "clients", "demo", "--connect", service.endpoint, "--user", "bob",
                        "--out", str(out), "--quiet"], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "using the running service" in r.stderr and "embedded" not in r.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with _client(service, "bob") as bob:
        (stats,) = bob.stats()
    asked, asked_before = stats.data["requests"], before.data["requests"]
    assert asked["load"] == asked_before["load"] and asked["move"] > asked_before["move"]


@pytest.mark.parametrize(("text", "message"), [
    ("alice\n", "line 1: expected user:password"),
    ("alice:pw\nbob:\n", "line 2: expected user:password"),
    ("alice:pw\n\nal*ce:pw\n", "line 3: user name 'al*ce'"),
    ("alice:pw\nalice:other\n", "line 2: user 'alice' given twice"),
    ("\n\n", "no user"),
])
def test_a_bad_users_file_is_named_with_its_line(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "users.txt"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(AccountsError) as e:
        Accounts.load(path)
    assert message in str(e.value)


def test_admins_are_users_of_the_file(users_file: Path) -> None:
    accounts = Accounts.load(users_file, ["bob", "bob"])
    assert accounts.admins == ("bob",)
    assert accounts.is_admin("bob") and not accounts.is_admin("alice") and not accounts.is_admin("carol")
    assert Accounts.load(users_file).admins == ()


def test_users_file_passwords_may_hold_colons(tmp_path: Path) -> None:
    path = tmp_path / "users.txt"
    path.write_text("alice:a:b:c\nbob.builder:x\n", encoding="utf-8")
    assert Accounts.load(path).users == ("alice", "bob.builder")


@pytest.mark.parametrize(("extra", "message"), [
    (["--users", "/nonexistent/users.txt"], "users file /nonexistent/users.txt"),
    (["--users", "USERS", "--cluster", "CLUSTER"], "names no 'password' file"),
    (["--users", "USERS", "--workers", "2", "--cluster", "CLUSTER"], "names no 'password' file"),
    (["--admin", "alice"], "--admin needs --users"),
    (["--users", "USERS", "--admin", "alice", "--admin", "carol"], "--admin 'carol': not a user"),
    (["--users", "USERS", "--workers", "2", "--admin", "carol"], "--admin 'carol': not a user"),
])
def test_serve_refuses_what_it_cannot_do_with_accounts(users_file: Path, tmp_path: Path, extra: list[str],
                                                        message: str) -> None:
    make_certificates(tmp_path)
    no_password = cluster_file(tmp_path, "a", [tls_endpoint()], [])
    args = [a.replace("USERS", str(users_file)).replace("CLUSTER", str(no_password)) for a in extra]
    proc = subprocess.run([sys.executable, "-m", "service", "--scene", str(ROOT / "clients/demo/demo.json"),
                           "--listen", "tcp/127.0.0.1:1", *args], cwd=ROOT, env=child_env(), capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 2
    assert message in proc.stderr, proc.stderr


def test_each_users_movers_come_back_after_a_restart(users_file: Path, tmp_path: Path) -> None:
    """`--state FILE` keeps each user's movers in `FILE.user-USER`; a restart gives each user its own back,
    though both used the same id."""
    state = tmp_path / "movers.state"
    extra = ["--users", str(users_file), "--state", str(state), "--state-interval", "0"]
    with ServiceProcess(extra=extra) as svc:
        with _client(svc, "alice") as alice, _client(svc, "bob") as bob:
            alice.register(human(), _ground(30.0), mover_id=0x77)
            hers = alice.move(0x77, offset=(0.25, 0.0, 0.0))
            his = bob.register(human(), _ground(70.0), mover_id=0x77)
        assert svc.stop() == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["movers.state.user-alice", "movers.state.user-bob"]
    with ServiceProcess(extra=extra) as svc:
        with _client(svc, "alice") as alice, _client(svc, "bob") as bob:
            alice.locate(0x77, hers.landblock)
            bob.locate(0x77, his.landblock)
            back_hers, back_his = alice.get(0x77)[0], bob.get(0x77)[0]
    assert (back_hers.seq, back_hers.position.origin) == (1, hers.position.origin)
    assert (back_his.seq, back_his.position.origin) == (0, his.position.origin)
    assert back_hers.position.origin != back_his.position.origin



def test_workers_keep_each_users_movers_apart(users_file: Path) -> None:
    """`--workers 2 --users`: alice's mover walks from the west worker's landblock into the east one's (a
    hand-over between the workers, in her space); bob reaches it on neither, cannot hand a mover over
    himself, and each user's Health counts that user's movers over both workers; only the admin (`--admin alice`)
    unloads a worker's landblock, which the service's landblock list then leaves out."""
    with ServiceProcess(extra=["--users", str(users_file), "--workers", "2", "--admin", "alice"]) as svc:
        with _client(svc, "alice") as alice, _client(svc, "bob") as bob:
            seen: list[int] = []
            sub = alice.subscribe(lambda st: seen.append(st.seq), mover_id=0x705)
            time.sleep(0.5)
            _walk_east_across(alice, 0x705)
            assert wait_until(lambda: seen[-1:] == [12], timeout=5.0), seen
            sub.close()
            assert seen == list(range(0, 13))  # the register's State, then every move's, in order
            assert [i.data["workers"] for i in alice.health()] == [2]
            assert [i.data["movers"] for i in alice.health()] == [1]
            assert [i.data["movers"] for i in bob.health()] == [0]
            _out_of_reach(bob, 0x705)
            raw = _session(svc, "bob")
            try:
                for key in ("acphys/u/bob/lb/AAB4/handover", "acphys/u/bob/lb/AAB4/*", "acphys/u/alice/lb/AAB4/get"):
                    assert _replies(raw, key, _forged_handover(0x51)) == [], key
            finally:
                raw.close()
            with pytest.raises(ServiceError):
                bob.find(0x51, timeout=2.0)
            assert alice.get(0x705)[0].seq == 12
            # the west worker's landblock, empty now: bob may not unload it, the admin may
            with pytest.raises(ServiceError) as e:
                bob.unload_landblock(0xA9B4)
            assert e.value.kind == "forbidden"
            (before,) = alice.landblocks()
            assert 0xA9B4 in before["loaded"]
            alice.unload_landblock(0xA9B4)
            with pytest.raises(ServiceError) as e:
                alice.unload_landblock(0xA9B4)  # its owner holds it no more
            assert e.value.kind == "landblock_not_loaded"
            # the service serves it no more, though the other worker keeps its copy of the scene's landblocks
            (after,) = alice.landblocks()
            assert after["loaded"] == sorted(set(before["loaded"]) - {0xA9B4})
            copies = [w["loaded"] for w in after["worker_processes"] if 0xA9B4 not in (w["owned"] if isinstance(w["owned"], list) else [])]
            assert len(copies) == 1 and 0xA9B4 in copies[0], after["worker_processes"]
            (stats,) = alice.stats()
            assert stats["loaded_landblocks"] == after["loaded"]


def test_a_cluster_keeps_each_users_movers_apart(users_file: Path, tmp_path: Path) -> None:
    """Two instances with accounts, joined by mutual TLS and the cluster file's password: alice's mover walks
    from instance A's landblock into B's (a hand-over in her space); bob, connected to B, reaches it on
    neither, and B takes no hand-over from him."""
    make_certificates(tmp_path)
    a_tls, b_tls = tls_endpoint(), tls_endpoint()
    a_file = cluster_file(tmp_path, "a", [a_tls], [], password="instances-only-7")
    b_file = cluster_file(tmp_path, "b", [b_tls], [a_tls], password="instances-only-7")
    users = ["--users", str(users_file)]
    with ServiceProcess(own="A9B4,A9B5", extra=[*users, "--cluster", str(a_file)]) as a, \
            ServiceProcess(own="AAB4,AAB5", extra=[*users, "--cluster", str(b_file)]) as b:
        with _client(a, "alice") as alice, _client(b, "bob") as bob:
            alice.wait_ready(instances=2)
            _walk_east_across(alice, 0x706)
            assert sorted(i.data["movers"] for i in alice.health()) == [0, 1]  # now held by B
            _out_of_reach(bob, 0x706)
            raw = _session(b, "bob")
            try:
                for key in ("acphys/u/bob/lb/AAB4/handover", "acphys/u/alice/lb/AAB4/handover",
                            "acphys/u/alice/lb/AAB4/get"):
                    assert _replies(raw, key, _forged_handover(0x52)) == [], key
            finally:
                raw.close()
            assert alice.get(0x706)[0].seq == 12


@contextmanager
def _running(args: list[str], marker: str) -> Iterator[list[str]]:
    """A process started with `args`, once it printed `marker`; its output lines. Always stopped."""
    proc = subprocess.Popen(args, cwd=ROOT, env=child_env(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)
    output: list[str] = []
    ready = threading.Event()

    def pump() -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            output.append(line)
            if marker in line:
                ready.set()

    threading.Thread(target=pump, daemon=True).start()
    try:
        deadline = time.monotonic() + 60.0
        while not ready.wait(0.05):
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"{args} did not start:\n" + "".join(output))
        yield output
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(20)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(10)


def test_a_router_checks_the_logins_for_the_instances_behind_it(users_file: Path, tmp_path: Path) -> None:
    """`acphys router --users --cluster`: clients log in at the router, the instances behind it (client mode,
    TLS) log in with the cluster's password; alice's mover crosses from the west instance to the east one,
    bob (at the same router) reaches it on neither, and a client without a login reaches nothing."""
    make_certificates(tmp_path)
    router_tls, router_plain = tls_endpoint(), f"tcp/127.0.0.1:{free_port()}"
    router = cluster_file(tmp_path, "router", [router_tls], [], password="behind-the-router")
    member = cluster_file(tmp_path, "member", [], [router_tls], password="behind-the-router")
    users = ["--users", str(users_file)]

    def instance(own: str) -> list[str]:
        return [sys.executable, "-m", "service", "--scene", str(ROOT / "clients/demo/demo.json"), "--own", own,
                "--mode", "client", "--listen", f"tcp/127.0.0.1:{free_port()}", "--cluster", str(member),
                "--log-level", "WARNING", *users]

    with _running([sys.executable, "-m", "clients", "router", "--listen", router_plain, "--cluster", str(router),
                   "--log-level", "WARNING", *users], "acphys router ready"), \
            _running(instance("A9B4,A9B5"), "acphys service ready"), \
            _running(instance("AAB4,AAB5"), "acphys service ready"):
        with Client([router_plain], user="alice", password=USERS["alice"], timeout=10.0) as alice, \
                Client([router_plain], user="bob", password=USERS["bob"], timeout=10.0) as bob:
            assert len(alice.wait_ready(instances=2, timeout=30.0)) == 2
            _walk_east_across(alice, 0x707)
            _out_of_reach(bob, 0x707)
            assert alice.get(0x707)[0].seq == 12
        anonymous = zenoh.open(make_config(connect=[router_plain]))
        try:
            assert list(anonymous.get("acphys/**", timeout=1.0)) == []
        finally:
            anonymous.close()
