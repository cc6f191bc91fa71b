"""Start-up and end of a short `cosim run`: the process ends as soon as the command is done, with
its exit handlers run and its output flushed, and loads only what the scene needs."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SKIP = ROOT / "scenarios" / "skip.yaml"


def run_program(code: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """Run ``code`` in a new interpreter, as the program (cosim.cli.main() with no arguments)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=300)


def test_a_run_as_the_program_runs_the_exit_handlers_flushes_and_leaves_a_complete_recording(tmp_path):
    out = tmp_path / "short.mcap"
    done = run_program(f"""
        import atexit, sys
        import cosim.cli
        atexit.register(lambda: print("exit handler ran"))
        sys.stdout.write("buffered, not yet flushed ")
        sys.argv = ["cosim", "run", {str(SKIP)!r}, "--until", "0.001", "-q", "-o", {str(out)!r}]
        sys.exit(cosim.cli.main())
    """, tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("buffered, not yet flushed skip: ok - reached t = 0.001 s")
    assert done.stdout.rstrip().endswith("exit handler ran")
    from cosim.record.reader import Recording

    assert Recording(out).scene().name == "skip"


def test_the_exit_code_of_a_command_that_failed_is_kept(tmp_path):
    done = run_program("""
        import sys
        import cosim.cli
        sys.argv = ["cosim", "run", "no_such_scene.yaml", "-q"]
        sys.exit(cosim.cli.main())
    """, tmp_path)
    assert done.returncode == 2
    assert "no_such_scene.yaml" in done.stderr


def test_a_thread_left_running_is_waited_for_as_at_a_normal_exit(tmp_path):
    done = run_program(f"""
        import sys, threading
        import cosim.cli
        returned = threading.Event()
        def late():  # still running when main() is done: it finishes after main() has returned
            returned.wait()
            print("thread finished")
        threading.Thread(target=late).start()
        sys.argv = ["cosim", "validate", {str(SKIP)!r}]
        code = cosim.cli.main()
        print("main returned")
        returned.set()
        sys.exit(code)
    """, tmp_path)
    assert done.returncode == 0, done.stderr
    assert "main returned" in done.stdout and "thread finished" in done.stdout


def test_main_called_with_arguments_returns_to_its_caller(tmp_path):
    done = run_program(f"""
        import cosim.cli
        code = cosim.cli.main(["validate", {str(SKIP)!r}])
        print("returned", code)
    """, tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.rstrip().endswith("returned 0")


def test_a_profiled_run_still_gets_its_profile_written(tmp_path):
    """Under `python -m cProfile` the process exits normally, so the profiler writes its file."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    profile = tmp_path / "run.prof"
    done = subprocess.run([sys.executable, "-m", "cProfile", "-o", str(profile), "-m", "cosim.cli", "validate",
                           str(SKIP)], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert profile.stat().st_size > 0


GC_STATE = """
    import atexit, gc, sys
    import cosim.cli, cosim.runner
    seen = {{}}
    real_run = cosim.runner.Simulation.run
    def run(self, *args, **kwargs):  # the collector's state when the steps begin
        seen["run"] = (gc.isenabled(), gc.get_freeze_count() > 0)
        return real_run(self, *args, **kwargs)
    cosim.runner.Simulation.run = run
    atexit.register(lambda: print("at exit", gc.isenabled(), "run", seen.get("run")))
    {call}
"""


def test_the_collector_is_paused_while_a_run_starts_and_back_for_the_steps(tmp_path):
    """Run as the program, `cosim run` starts up without the cyclic garbage collector and turns it
    back on, with the start-up's objects frozen, before the first step."""
    done = run_program(GC_STATE.format(call=f"""
    sys.argv = ["cosim", "run", {str(SKIP)!r}, "--until", "0.001", "-q", "--no-record"]
    sys.exit(cosim.cli.main())"""), tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.rstrip().endswith("at exit True run (True, True)")


def test_a_start_up_that_fails_turns_the_collector_back_on(tmp_path):
    done = run_program(GC_STATE.format(call="""
    sys.argv = ["cosim", "run", "no_such_scene.yaml", "-q"]
    sys.exit(cosim.cli.main())"""), tmp_path)
    assert done.returncode == 2
    assert done.stdout.rstrip().endswith("at exit True run None")


def test_main_called_with_arguments_leaves_the_collector_alone(tmp_path):
    done = run_program(GC_STATE.format(call=f"""
    code = cosim.cli.main(["run", {str(SKIP)!r}, "--until", "0.001", "-q", "--no-record"])
    sys.exit(code)"""), tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.rstrip().endswith("at exit True run (True, False)")


def test_whether_a_kernel_was_compiled_is_known_once_watched(tmp_path):
    done = run_program("""
        import sys
        from cosim import jit_time
        print(jit_time.may_have_compiled())  # no numba: nothing compiled
        import numba
        print(jit_time.may_have_compiled())  # numba, unwatched: cannot tell
        jit_time.watch_compiles()
        print(jit_time.may_have_compiled())
        numba.njit(lambda x: x + 1)(1)
        print(jit_time.may_have_compiled())
    """, tmp_path)
    assert done.stdout.split() == ["False", "True", "False", "True"], done.stderr


def test_a_start_up_that_compiled_kernels_is_collected_before_it_is_frozen(tmp_path):
    """With an empty kernel cache the start-up compiles; its garbage is collected (a full collection)
    when the run begins, and a start-up that only loaded kernels is frozen without one."""
    code = f"""
        import gc, sys
        import cosim.cli
        real = cosim.cli.start_up_done
        def done():
            before = gc.get_stats()[2]["collections"]
            real()
            print("full collections", gc.get_stats()[2]["collections"] - before)
            cosim.cli.start_up_done = real
        cosim.cli.start_up_done = done
        sys.argv = ["cosim", "run", {str(SKIP)!r}, "--until", "0.001", "-q", "--no-record"]
        sys.exit(cosim.cli.main())
    """
    env = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_CACHE_DIR": str(tmp_path / "kernels")}
    for expected in ("full collections 1", "full collections 0"):  # compiled, then loaded
        done = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], cwd=tmp_path, env=env,
                              capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr
        assert expected in done.stdout.splitlines()
