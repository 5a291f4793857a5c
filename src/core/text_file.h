// Writing a whole text file so that readers never see a partial one: the text goes to a
// temporary file next to the target, which is renamed over it when complete (POSIX rename is
// atomic within a file system). On any error the temporary file is removed and nothing changes.
#pragma once

#include <filesystem>
#include <string_view>

#include "core/result.h"

namespace mds {

// Errc::io naming the file when it cannot be written or renamed into place.
Status write_text_atomically(const std::filesystem::path& path, std::string_view text);

}  // namespace mds
