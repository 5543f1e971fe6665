"""What the studies under runs/ share: where msim is, the environment its runs need (Open MPI as
root and oversubscribed, single-threaded BLAS so rank counts mean cores), the benchmark cloth, and
PETSc -log_view events, a table of rows as CSV. Import with sys.path pointing at runs/tools."""
import argparse
import csv
import os
import re

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MSIM = os.path.join(ROOT, "build", "msim")
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_rmaps_base_oversubscribe="1", OPENBLAS_NUM_THREADS="1")
# the benchmark cloth of issue-tracked targets: 101 x 101, 1 m, 1 kg, k = 1000 N/m, h = 1/30 s
BENCH_CLOTH = "-msim_cloth_n 101 -msim_integrator implicit_euler -msim_dt 0.0333333333333333"


def event(log, name, stage=None):
    """(count, max time in s) of a -log_view event, summed over msim's stages or only in the named
    one ("Setup", "Stepping"); (0, 0.0) where the run did not log it"""
    if stage:
        m = re.search(rf"^--- Event Stage \d+: {stage}\s*$(.*?)(?=^--- Event Stage|\Z)", log, re.M | re.S)
        log = m.group(1) if m else ""
    hits = re.findall(rf"^{name}\s+(\d+)\s+\S+\s+(\S+)\s+\S+", log, re.M)
    return (sum(int(c) for c, _ in hits), sum(float(t) for _, t in hits))


def write_csv(path, rows):
    """rows (dicts, in column order) as a CSV file with a header line: every key of any row, in the
    order first seen (a row without one leaves its cell empty)"""
    fields = []
    for r in rows:
        fields += [k for k in r if k not in fields]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)


def study_parser(parts):
    """a study's command line: which part to run (parts, the last the default) and --msim"""
    p = argparse.ArgumentParser()
    p.add_argument("part", nargs="?", default=parts[-1], choices=parts)
    p.add_argument("--msim", default=MSIM)
    return p
