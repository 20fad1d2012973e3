// Linked into every benchmark binary (thermovis_add_benchmark): the benchmarks measure the
// stages with the heap policy the services and the command line run them with, not with glibc's
// default, under which a stage's fresh buffers fault their pages in again on every call.
#include "thermovis/util/heap.hpp"

namespace {

const bool kHeapKept = [] {
  thermovis::util::keep_freed_heap();
  return true;
}();

}  // namespace
