// The phones of an utterance in an HDF5 group: GROUP/phones (names, with the alphabet as an
// attribute), GROUP/times (start and end of each, seconds) and GROUP/visemes (lipsync::Viseme,
// names as an attribute). synth clip keeps the truth of a talking clip under /speech;
// lipsync audio keeps what it recognized under /lipsync.
#ifndef FACECAP_STAGES_SPEECH_FILE_H_
#define FACECAP_STAGES_SPEECH_FILE_H_

#include <string>
#include <vector>

#include "io/hdf5.h"
#include "lipsync/speech_track.h"

namespace facecap::stages {

void WritePhones(io::H5File* f, const std::string& group,
                 const std::vector<lipsync::PhoneSegment>& phones, const std::string& alphabet,
                 const std::string& clock);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_SPEECH_FILE_H_
