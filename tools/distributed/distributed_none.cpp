// Built without MPI: one process renders everything.
#include "tools/distributed/distributed.h"

namespace dist {

World init(int&, char**&, const char*) { return {}; }
void finalize() {}
void abort_job(int) {}
std::unique_ptr<renderer::TileSource> make_tile_source(const World&) { return nullptr; }
std::vector<std::string> gather(const World&, const std::vector<std::string>& mine, size_t) { return mine; }

void broadcast(const World&, std::string&) {}

}  // namespace dist
