"""Runs a command and appends "wall_s cpu_s maxrss_kb" to a file: wall time around fork and exec,
user + system CPU and peak RSS from wait4(2), in microseconds (GNU time prints hundredths of a
second, too coarse for a process of 50 ms). Used by bench/lib.sh's `timed`.

    python3 bench/rusage.py TIMES_FILE ERR_FILE COMMAND [ARGS...]

The command's standard output is discarded and its standard error goes to ERR_FILE; the exit
status is the command's (128 + signal when a signal ended it).
"""
import os
import sys
import time


def main() -> int:
    times_file, err_file, command = sys.argv[1], sys.argv[2], sys.argv[3:]
    with open(os.devnull, "wb") as null, open(err_file, "wb") as err:
        start = time.perf_counter()
        pid = os.fork()
        if pid == 0:
            os.dup2(null.fileno(), 1)
            os.dup2(err.fileno(), 2)
            try:
                os.execvp(command[0], command)
            finally:
                os._exit(127)
        _, status, usage = os.wait4(pid, 0)
        wall = time.perf_counter() - start
    with open(times_file, "a", encoding="ascii") as out:
        out.write(f"{wall:.6f} {usage.ru_utime + usage.ru_stime:.6f} {usage.ru_maxrss}\n")
    return os.waitstatus_to_exitcode(status) if os.WIFEXITED(status) else 128 + os.WTERMSIG(status)


if __name__ == "__main__":
    sys.exit(main())
