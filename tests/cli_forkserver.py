"""Run many ``torchrom`` command lines as real processes, fast: a fork server.

One Python process imports torchrom (and torch, numpy, pandas, pyNastran) once; for every
request it forks a child that runs the console script's entry point ``torchrom.cli.main`` on
its own argv, working directory, stdout and stderr, and exits the way the interpreter does
(an uncaught exception prints its traceback and exits 1; ``SystemExit`` its code). The parent
returns the child's exit status and its captured output. A child is a separate process like
``python -m torchrom`` — its own exit status, file descriptors and memory — without paying the
imports again (about 2 s per command, 7 s and more on a loaded machine).

Protocol: one JSON request per line on stdin ``{"argv": [...], "cwd": "..."}``, one JSON
reply per line on stdout ``{"rc": int, "stdout": str, "stderr": str}``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile

#: seconds a child may run before it is killed (a refusal takes well under one)
CHILD_TIMEOUT_S = 120


def _child(argv: list[str], cwd: str, out_path: str, err_path: str) -> None:
    """In the forked child: the interpreter's behaviour around ``sys.exit(main())``."""
    code = 1
    try:
        os.chdir(cwd)
        for fd, path in ((1, out_path), (2, err_path)):
            f = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
            os.dup2(f, fd)
            os.close(f)
        sys.stdout = open(1, "w", closefd=False)
        sys.stderr = open(2, "w", closefd=False)
        sys.argv = ["torchrom", *argv]
        from torchrom.cli import main

        try:
            code = main(argv)
            code = 0 if code is None else int(code)
        except SystemExit as exc:
            if exc.code is None:
                code = 0
            elif isinstance(exc.code, int):
                code = exc.code
            else:
                print(exc.code, file=sys.stderr)
                code = 1
        except BaseException:  # noqa: BLE001 - what the interpreter does with an uncaught one
            import traceback

            traceback.print_exc()
            code = 1
    finally:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(code)


def _serve() -> None:
    import importlib
    import signal

    from torchrom.cli import build_parser

    build_parser()  # imports every command module
    # what the commands import when they run (each child would pay it again)
    for name in ("pandas", "pyarrow.parquet", "pyNastran.bdf.bdf", "torchrom.fe",
                 "torchrom.study.config", "torchrom.study.sweep", "torchrom.study.runner",
                 "torchrom.aero.build", "torchrom.aero.files", "torchrom.aero.nastran_flutter",
                 "torchrom.identify.build", "torchrom.fe.update", "matplotlib.pyplot",
                 "torchrom.study.plots", "torchrom.study.figures"):
        importlib.import_module(name)

    tmp = tempfile.mkdtemp(prefix="torchrom-forkserver-")
    out_path, err_path = os.path.join(tmp, "stdout"), os.path.join(tmp, "stderr")
    for line in sys.stdin:
        req = json.loads(line)
        pid = os.fork()
        if pid == 0:
            _child(req["argv"], req["cwd"], out_path, err_path)
        signal.signal(signal.SIGALRM, lambda *_, child=pid: os.kill(child, signal.SIGKILL))
        signal.alarm(CHILD_TIMEOUT_S)
        _, status = os.waitpid(pid, 0)
        signal.alarm(0)
        rc = os.waitstatus_to_exitcode(status)
        with open(out_path, errors="replace") as f_out, open(err_path, errors="replace") as f_err:
            reply = {"rc": rc, "stdout": f_out.read(), "stderr": f_err.read()}
        sys.__stdout__.write(json.dumps(reply) + "\n")
        sys.__stdout__.flush()


class ForkServer:
    """The parent side: ``run(argv, cwd)`` -> (exit status, stdout, stderr)."""

    def __init__(self, env: dict[str, str] | None = None):
        self.proc = subprocess.Popen([sys.executable, "-m", "tests.cli_forkserver"],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                                     env=env, cwd=os.path.dirname(os.path.dirname(__file__)))

    def run(self, argv, cwd) -> tuple[int, str, str]:
        self.proc.stdin.write(json.dumps({"argv": [str(a) for a in argv],
                                          "cwd": str(cwd)}) + "\n")
        self.proc.stdin.flush()
        reply = json.loads(self.proc.stdout.readline())
        return reply["rc"], reply["stdout"], reply["stderr"]

    def close(self) -> None:
        self.proc.stdin.close()
        self.proc.wait(timeout=30)


if __name__ == "__main__":
    _serve()
