"""A pcsg command run on a pseudo-terminal, for what it shows only to a person at one
(progress lines, the notice that the kernels compile)."""
import os
import pty
import select
import subprocess
import sys
import time


def on_a_terminal(args, env, until, timeout=180.0):
    """The command's output on a pseudo-terminal, read until `until` shows or it ends;
    then the command is stopped (a cold start would go on compiling for minutes)."""
    master, slave = pty.openpty()
    p = subprocess.Popen([sys.executable, "-m", "pcsg.cli", *args], stdin=slave,
                         stdout=slave, stderr=slave, env=env)
    os.close(slave)
    out, end = b"", time.monotonic() + timeout
    try:
        while until not in out and time.monotonic() < end:
            if select.select([master], [], [], 0.2)[0]:
                try:
                    chunk = os.read(master, 4096)
                except OSError:     # the command ended and closed the terminal
                    break
                out += chunk
            elif p.poll() is not None:
                break
    finally:
        p.kill()
        p.wait()
        os.close(master)
    return out
