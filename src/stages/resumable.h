// Opening the output of a resumable stage (rank 0).
//
// - The final file exists and was made with the same configuration: it is up to date, nothing
//   to do.
// - A `.partial` file exists and was made with the same configuration: continue it.
// - A `.partial` made with another configuration: InvalidInputError that says so (delete it or
//   rerun with the same options), never a silent mix of two configurations.
// - Otherwise: a new `.partial` file.
// The configuration hash is kept in the root attribute `config_hash`.
#ifndef FACECAP_STAGES_RESUMABLE_H_
#define FACECAP_STAGES_RESUMABLE_H_

#include <string>

#include "io/hdf5.h"

namespace facecap::stages {

struct ResumableOutput {
  io::H5File file;          // open .partial file (not open when up_to_date)
  bool up_to_date = false;  // the final file already holds this configuration's result
  bool resumed = false;     // continuing a .partial file
};

ResumableOutput OpenResumableOutput(const std::string& path, const std::string& config_text,
                                    const io::Provenance& provenance);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_RESUMABLE_H_
