"""What the kill tests share: ending a run, one rank or mpirun and its ranks, with SIGKILL."""
import os
import signal
import subprocess
import time


def kill_all(p):
    """SIGKILL to mpirun's ranks (Open MPI puts them in process groups of their own) and to mpirun
    or the single msim, at once; returns when none is left"""
    ranks = [int(x) for x in subprocess.run(["pgrep", "-P", str(p.pid)], capture_output=True, text=True).stdout.split()]
    for pid in ranks + [p.pid]:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    p.wait()
    deadline = time.time() + 10  # a zombie no init reaps stays listed: give up waiting then
    for pid in ranks:
        while time.time() < deadline:
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                break
            time.sleep(0.01)
