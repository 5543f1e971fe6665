/* Umbrella over the headers split from it by job: petsc_compat.h (PETSc and version shims), log.h
   (log events and stages), init.h (start-up, shut-down, registration), errors.h (one-line errors,
   rank-0 calls), options.h (option readers), crash_guard.h, signals.h (stop on SIGINT/SIGTERM).
   Kept while files still include it; new code includes the headers it needs, and this file goes
   once nothing includes it. */
#pragma once
#include <msim/petsc_compat.h>
#include <msim/log.h>
#include <msim/init.h>
#include <msim/errors.h>
#include <msim/options.h>
#include <msim/crash_guard.h>
#include <msim/signals.h>
