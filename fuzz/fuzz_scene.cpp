// libFuzzer target for the scene parser (P8): any text either parses into a scene or fails with
// an InputError (a SceneError: file, line, key, what was expected). Anything else escaping --
// another exception, a crash, a sanitizer report -- is a bug libFuzzer stops on.
//
//   cmake -S fuzz -B build/fuzz -DCMAKE_CXX_COMPILER=clang++ && cmake --build build/fuzz
//   build/fuzz/fuzz_scene -max_total_time=600 -dict=fuzz/scene.dict build/fuzz/corpus scenes/
#include "core/Error.hpp"
#include "domain/Scene.hpp"

#include <cstddef>
#include <cstdint>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    (void)kf::parse_scene(text, "fuzz.toml");
  } catch (const kf::InputError&) {
    // The answer to bad input.
  }
  return 0;
}
