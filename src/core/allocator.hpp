#pragma once
// Private to printtwin's programs (the command line, the benchmarks): the process-wide
// allocator policy. Implemented in core/io.cpp.

namespace printtwin {

/// Tunes the C library's allocator for printtwin's jobs, one job per process whose stages
/// free and re-allocate many large temporary arrays (deviation bit columns, sample arrays,
/// images; for compare, every variant's): freed blocks of up to 32 MiB stay in the process
/// instead of going back to the kernel and being faulted back in zeroed. Called first by
/// the command line and by the deviation benchmark (so it measures the stage as the command
/// line runs it). glibc only; elsewhere it does nothing.
void tune_allocator_for_jobs();

}  // namespace printtwin
