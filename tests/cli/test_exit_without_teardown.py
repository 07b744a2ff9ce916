"""The ``feedtune`` command ends without the interpreter's teardown (feedtune/__main__.py):
what the process owes (atexit handlers, buffered output, running threads, the exit status)
must still be done."""

import subprocess
import sys
import textwrap


def run(body: str, tmp_path):
    script = textwrap.dedent("""
        import atexit, sys, threading, time
        from feedtune.__main__ import exit_without_teardown
    """) + textwrap.dedent(body)
    return subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          cwd=tmp_path, timeout=60)


def test_status_buffered_output_and_atexit_handlers_survive(tmp_path):
    done = run("""
        atexit.register(lambda: open("atexit.txt", "w").write("ran"))
        sys.stdout.write("no newline, still buffered")
        exit_without_teardown(3)
    """, tmp_path)
    assert done.returncode == 3
    assert done.stdout == "no newline, still buffered"
    assert (tmp_path / "atexit.txt").read_text() == "ran"


def test_message_code_is_status_1_with_the_message_on_stderr(tmp_path):
    done = run("exit_without_teardown('error: something')", tmp_path)
    assert done.returncode == 1
    assert done.stderr.strip() == "error: something"


def test_none_is_status_0(tmp_path):
    assert run("exit_without_teardown(None)", tmp_path).returncode == 0


def test_a_running_non_daemon_thread_is_waited_for(tmp_path):
    done = run("""
        def late():
            time.sleep(0.3)
            open("thread.txt", "w").write("finished")
        threading.Thread(target=late).start()
        exit_without_teardown(4)
    """, tmp_path)
    assert done.returncode == 4
    assert (tmp_path / "thread.txt").read_text() == "finished"


def test_the_feedtune_command_keeps_its_exit_status_and_output(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    done = subprocess.run([sys.executable, "-m", "feedtune", "validate", str(bad)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert "error:" in done.stderr
    listed = subprocess.run([sys.executable, "-m", "feedtune", "examples"],
                            capture_output=True, text=True, timeout=120)
    assert listed.returncode == 0
    assert "koren-1979-sampled-data" in listed.stdout
