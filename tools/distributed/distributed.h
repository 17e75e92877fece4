// Rendering across processes under mpirun, kept behind this header so that nothing else
// includes mpi.h. Built without MPI (or started without mpirun), a process is rank 0 of 1
// and every call here is a no-op.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "renderer/render.h"

namespace dist {

/// This process's place in the job.
struct World {
    int rank = 0, size = 1;
    bool root() const { return rank == 0; }
};

/// Joins the MPI job when the process was started by mpirun. From then on, a rank that
/// exits before finalize() (a failed load: tools::fail, an exception) stops every rank
/// with a message naming it and the tail of its log. On ranks other than 0, stderr goes
/// to a private log that is shown only when that rank fails.
World init(int& argc, char**& argv, const char* prog);

/// Leaves the job cleanly; call on every rank before a normal exit.
void finalize();

/// Stops every rank now, as an exit before finalize() does, but with this exit status
/// (3: out of memory). A no-op outside an MPI job.
void abort_job(int status);

/// Rank 0 hands out tiles on demand and gathers the finished ones into its state; every
/// rank renders with all its threads. nullptr when the job has one rank.
std::unique_ptr<renderer::TileSource> make_tile_source(const World& world);

/// Work sharing for independent jobs (the tradeoff sweep): job i runs on rank i % size,
/// and gather() brings each job's text result to rank 0 in job order.
std::vector<std::string> gather(const World& world, const std::vector<std::string>& mine,
                                size_t jobs);

/// Rank 0's bytes, on every rank (e.g. a reference image only rank 0 gathered).
void broadcast(const World& world, std::string& bytes);

}  // namespace dist
