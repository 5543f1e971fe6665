"""What the Python tests share for their assertions: a tally of named checks, each printed as it is
made, and the exit code that fails the test when any check failed."""


class Checks:
    def __init__(self):
        self.failed = 0

    def __call__(self, ok, what):
        print(("ok  " if ok else "FAIL") + " " + what, flush=True)
        self.failed += 0 if ok else 1

    def exit_code(self):
        print("FAILED" if self.failed else "all passed")
        return 1 if self.failed else 0
