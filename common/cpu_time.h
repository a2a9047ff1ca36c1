// The CPU time of the whole process, to set beside a wall time: CPU/wall is the number of
// threads a stretch of work kept busy on average (≈ 1 serial, ≈ the thread count when every
// thread works), on any machine.
#pragma once

namespace plumage {

// CPU seconds used so far by all threads of this process (CLOCK_PROCESS_CPUTIME_ID); child
// processes (the plotter) are not counted. Differences of two calls give the CPU time of the
// work between them.
double process_cpu_seconds();

}  // namespace plumage
