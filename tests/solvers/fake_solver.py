"""A solver for the run engine's tests: each mode produces one outcome class.

Run in the run directory as `python3 fake_solver.py MODE [ARGS]`. The response goes to `resp.txt`
as `value = X`. Pid files (`solver.pid`, `grandchild.pid`) let tests check that processes died.

Modes:
  ok X            write the response X, exit 0
  exit CODE       exit with CODE, no response
  failtext        print an error-termination line, still write a response and exit 0
  noresp          exit 0 without a response file
  emptyresp       write an empty response file
  garbage         write a response file without a number
  hang            spawn a grandchild, write both pids, sleep far past any test timeout
  stubborn        like hang, but the solver and its grandchild ignore SIGTERM (only SIGKILL works)
  selfkill SIG    kill itself with signal number SIG
  flaky N X       fail (exit 1) on the first N attempts, counted in count.txt; then write X
  slow SECS X     write solver.pid, sleep SECS, then write X
"""

import os
import signal
import subprocess
import sys
import time


def respond(x):
    with open("resp.txt", "w") as f:
        f.write(f"header line\nvalue = {x}\n")


def write_pid(name, pid):
    with open(name + ".tmp", "w") as f:
        f.write(str(pid))
    os.rename(name + ".tmp", name)  # tests never see a half-written pid


def hang():
    grandchild = subprocess.Popen(["sleep", "60"])
    write_pid("grandchild.pid", grandchild.pid)
    write_pid("solver.pid", os.getpid())
    time.sleep(60)


def main():
    mode, args = sys.argv[1], sys.argv[2:]
    if mode == "ok":
        respond(args[0])
    elif mode == "exit":
        sys.exit(int(args[0]))
    elif mode == "failtext":
        print(" E r r o r    t e r m i n a t i o n     01/01/26 12:00:00", flush=True)
        respond("1.0")
    elif mode == "noresp":
        pass
    elif mode == "emptyresp":
        open("resp.txt", "w").close()
    elif mode == "garbage":
        with open("resp.txt", "w") as f:
            f.write("value = not-a-number\n")
    elif mode == "hang":
        hang()
    elif mode == "stubborn":
        signal.signal(signal.SIGTERM, signal.SIG_IGN)  # inherited by the grandchild across exec
        hang()
    elif mode == "selfkill":
        os.kill(os.getpid(), int(args[0]))
        time.sleep(5)
    elif mode == "flaky":
        n = int(open("count.txt").read()) if os.path.exists("count.txt") else 0
        with open("count.txt", "w") as f:
            f.write(str(n + 1))
        if n < int(args[0]):
            sys.exit(1)
        respond(args[1])
    elif mode == "slow":
        write_pid("solver.pid", os.getpid())
        time.sleep(float(args[0]))
        respond(args[1])
    else:
        sys.exit(f"unknown mode {mode}")


if __name__ == "__main__":
    main()
