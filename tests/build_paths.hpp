#pragma once
// Where the checkout and the shared data are. Functions, not compile definitions: the values are
// absolute paths of this checkout, and a macro holding one would enter the compiler-cache key of
// every test translation unit, so a clone in another folder would miss the cache for all of them.
// Defined in a few generated lines per executable (cmake/build_paths.cmake, maskadapt_build_paths).
#include <string>

namespace maskadapt::build_paths {

/// The source tree (CMAKE_SOURCE_DIR): assets/, configs/, models/, tests/fuzz/.
std::string source_dir();

/// The shared data directory configured into the build (MASKADAPT_DATA_DIR, default
/// <source>/../shared/data). Tests that read the MASKADAPT_DATA_DIR environment variable let it win.
std::string default_data_dir();

}  // namespace maskadapt::build_paths
