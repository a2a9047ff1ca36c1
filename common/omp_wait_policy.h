// How idle OpenMP threads wait: asleep (passive), not spinning, unless the user chose otherwise.
//
// Why: with OMP_WAIT_POLICY unset, libgomp lets a thread that has run out of work spin for
// 300 000 iterations (milliseconds) before it sleeps: at the end of every parallel loop, while
// the others finish, and between parallel regions. On an idle machine that only burns a core
// nobody wanted. When another process holds one of the cores, the spinning thread takes CPU from
// the threads that still work, or keeps one that was preempted in the middle of its share off
// the core: the quick species study took 34.9 s on 2 threads against 19.7 s on 1 (CPU 34.3 s
// against 19.2 s), most of the difference in the Filip fits, whose Levenberg–Marquardt steps
// alternate a short parallel pass with serial algebra hundreds of times. A sleeping thread costs
// a wake-up (tens of microseconds) per parallel region, which regions of milliseconds and more
// do not notice (bench/busy_core_threads.sh measures both cases).
//
// libgomp reads OMP_WAIT_POLICY once, when it is loaded, before main runs; setting it in main is
// too late, and libgomp has no call to change it afterwards. (Nor does an executable's
// .preinit_array help: it runs before the C library sets up the environment, which then
// replaces whatever was set.) So the process sets the variable and executes itself again, once.
#pragma once

namespace plumage {

// Call early in main, after the interrupt handler is installed (common/interrupt.h) and before
// anything is written, locked or spoken to (an MPI launcher included): exec ends every thread.
// When neither OMP_WAIT_POLICY nor GOMP_SPINCOUNT is set (either is the user's choice of how to
// wait, which wins) and no Ctrl-C has come, sets OMP_WAIT_POLICY=passive and replaces the
// process by the same program with the same arguments (the file /proc/self/exe names, if it is
// still the running one; the process id and name stay). SIGINT and SIGTERM are blocked across
// the exec and unblocked when the new process calls this in turn, so a Ctrl-C during the second
// start reaches its handler (the run stops at its first stage) rather than killing it; they are
// unblocked on return in any case. Returns only when nothing was to be done or the re-execution
// was impossible (no /proc, the program file replaced since the start): the run then goes on
// with libgomp's default and the environment as it was. The variable stays in the new process's
// environment, so child processes wait alike.
void wait_passively_unless_told(char** argv);

}  // namespace plumage
