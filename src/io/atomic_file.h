// Whole files written atomically: readers see the old file or the complete new one, never a
// partial one (a temporary name, then a rename).
#ifndef FACECAP_IO_ATOMIC_FILE_H_
#define FACECAP_IO_ATOMIC_FILE_H_

#include <string>

namespace facecap::io {

// Writes `contents` to path + ".tmp" and renames it to `path`. OutputError naming the file when
// it cannot be created, written or renamed.
void WriteFileAtomically(const std::string& path, const std::string& contents);

}  // namespace facecap::io

#endif  // FACECAP_IO_ATOMIC_FILE_H_
