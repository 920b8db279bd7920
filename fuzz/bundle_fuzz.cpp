// libFuzzer target: the bundle reader (HDF5), then verify's checks and inspect's
// summary, the three things `fissure-bake inspect`/`verify` and the player do with a
// bundle. HDF5 itself is not instrumented for coverage; the sanitizers still catch
// what it does to memory through the intercepted libc calls. After each input no HDF5
// object may stay open: a leaked handle would keep the file open for the life of the
// player.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include <hdf5.h>

#include "common/error.h"
#include "formats/bundle.h"
#include "formats/bundle_checks.h"
#include "formats/bundle_inspect.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = fissure::fuzz::write_input(fissure::fuzz::as_text(data, size), "bundle.h5");
  try {
    const fissure::formats::BundleSummary summary = fissure::formats::summarize_bundle(path);
    (void)fissure::formats::summary_text(summary);
    (void)fissure::formats::summary_json(summary);
    (void)fissure::formats::verify_bundle(summary.bundle);
  } catch (const fissure::Error&) {
  }
  const ssize_t open_objects = H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL);
  if (open_objects != 0) {
    std::fprintf(stderr, "bundle_fuzz: %zd HDF5 objects left open after reading the input\n", open_objects);
    std::abort();
  }
  return 0;
}
