"""Teardown: a failing test, a KeyboardInterrupt, a killed test process and xdist workers
never leave a cluster process behind. Each case runs an inner pytest session that records
the pids of its cluster; the outer test checks they are gone."""

import json
import signal
import time
from pathlib import Path

import pytest

from pytest_mcc._procs import start_time

INNER_CONFTEST = '''
import json, os
import pytest

def record(cluster, path):
    st = cluster.status()
    pids = [m["pid"] for m in st["members"]] + [st["supervisor"]["pid"]]
    with open(path, "a") as f:
        f.write(json.dumps({"pids": pids, "run": str(cluster.run_base)}) + "\\n")
'''


def recorded(path: Path):
    rows = [json.loads(line) for line in path.read_text().splitlines()]
    assert rows, "the inner test recorded no cluster"
    return rows


def wait_gone(pids, seconds=30.0):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        left = [p for p in pids if start_time(p) is not None]
        if not left:
            return []
        time.sleep(0.1)
    return left


@pytest.fixture
def inner(pytester, mcc):
    pytester.makeconftest(INNER_CONFTEST)
    pytester.makeini("[pytest]\nmcc_clock = lockstep\n")
    return pytester


def run_inner(pytester, mcc, *args, timeout=300):
    return pytester.runpytest_subprocess("-p", "no:cacheprovider", f"--mcc-bin={mcc}", *args,
                                         timeout=timeout)


def test_a_failing_test_tears_down_and_reports_the_logs(inner, mcc):
    pids = inner.path / "pids.jsonl"
    inner.makepyfile(f'''
        import pytest
        from conftest import record

        @pytest.mark.mcc(cards=1, stations=1)
        def test_fails(mcc_cluster):
            record(mcc_cluster, {str(pids)!r})
            assert mcc_cluster.send("I0", card=0) == "7"
    ''')
    res = run_inner(inner, mcc)
    res.assert_outcomes(failed=1)
    res.stdout.fnmatch_lines(["*mcc logs (pytest-*)*", "*--- supervisor ---*", "*running (pid*"])
    for row in recorded(pids):
        assert wait_gone(row["pids"]) == []
        assert not Path(row["run"]).exists()


def test_keyboard_interrupt_tears_down(inner, mcc):
    pids = inner.path / "pids.jsonl"
    inner.makepyfile(f'''
        from conftest import record

        def test_interrupted(mcc_cluster_factory):
            c = mcc_cluster_factory(cards=1, stations=1)
            record(c, {str(pids)!r})
            raise KeyboardInterrupt
    ''')
    res = run_inner(inner, mcc)
    assert res.ret == pytest.ExitCode.INTERRUPTED
    for row in recorded(pids):
        assert wait_gone(row["pids"]) == []


def test_a_killed_test_process_takes_its_cluster_with_it(inner, mcc):
    # SIGKILL: no finalizer, no atexit runs; the cluster follows its owner (--owner-pid).
    pids = inner.path / "pids.jsonl"
    inner.makepyfile(f'''
        import os, signal
        from conftest import record

        def test_killed(mcc_cluster_factory):
            c = mcc_cluster_factory(cards=1, stations=1)
            record(c, {str(pids)!r})
            os.kill(os.getpid(), signal.SIGKILL)
    ''')
    res = run_inner(inner, mcc)
    assert res.ret == -signal.SIGKILL or res.ret != 0
    for row in recorded(pids):
        assert wait_gone(row["pids"], 30.0) == [], "members outlived a killed test process"


def test_xdist_workers_each_run_and_tear_down_their_clusters(inner, mcc):
    pytest.importorskip("xdist")
    pids = inner.path / "pids.jsonl"
    inner.makepyfile(f'''
        import os
        import pytest
        from conftest import record

        @pytest.mark.parametrize("n", [0, 1])
        @pytest.mark.mcc(cards=1, stations=0)
        def test_worker(mcc_cluster, n):
            record(mcc_cluster, {str(pids)!r})
            assert mcc_cluster.send("I0", card=0) == "0"
            assert os.environ.get("PYTEST_XDIST_WORKER")
    ''')
    res = run_inner(inner, mcc, "-n", "2")
    res.assert_outcomes(passed=2)
    rows = recorded(pids)
    assert len(rows) == 2 and rows[0]["run"] != rows[1]["run"]
    for row in rows:
        assert wait_gone(row["pids"]) == []


def test_the_readme_example_runs_as_written(inner, mcc):
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    section = readme.split("## Testing your software against mcc", 1)[1]
    code = section.split("```python\n", 1)[1].split("```", 1)[0]
    inner.makepyfile(test_jog=code)
    res = run_inner(inner, mcc)
    res.assert_outcomes(passed=1)
