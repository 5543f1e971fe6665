/* crash_guard.cpp: runs fn; a crash signal inside it (SIGSEGV, SIGABRT, SIGFPE, SIGBUS, SIGILL)
   returns here as that signal's number (0: fn returned). For third-party calls on bad input. */
#pragma once
#include <functional>

int MSimCallGuarded(const std::function<void(void)> &fn);
