// Shared by the fuzz targets: a private scratch folder in memory (/dev/shm
// when there is one) for the readers that take a path, and quiet logging.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace relight::fuzz {

// Once per process: logging off, scratch folder created. Returns the folder.
const std::string& ScratchDir();
// Writes `bytes` to ScratchDir()/name and returns the path.
std::string WriteScratch(const std::string& name, std::string_view bytes);
// Splits `data` at every "\n%%\n" into at most `parts` pieces (the last takes the rest).
std::vector<std::string_view> SplitParts(std::string_view data, size_t parts);

}  // namespace relight::fuzz
