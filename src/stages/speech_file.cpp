#include "stages/speech_file.h"

#include <Eigen/Core>

#include "lipsync/visemes.h"

namespace facecap::stages {

void WritePhones(io::H5File* f, const std::string& group,
                 const std::vector<lipsync::PhoneSegment>& phones, const std::string& alphabet,
                 const std::string& clock) {
  std::vector<std::string> names;
  Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor> times(phones.size(), 2);
  std::vector<int> visemes;
  for (size_t i = 0; i < phones.size(); ++i) {
    names.push_back(phones[i].phone);
    times(i, 0) = phones[i].start;
    times(i, 1) = phones[i].end;
    visemes.push_back(phones[i].viseme);
  }
  f->WriteStrings(group + "/phones", names);
  f->SetAttribute(group + "/phones", "alphabet", alphabet);
  f->WriteMatrix(group + "/times", times);
  f->SetAttribute(group + "/times", "columns", "start, end (" + clock + ")");
  f->WriteVector<int>(group + "/visemes", visemes);
  std::string viseme_names;
  for (int v = 0; v < lipsync::kNumVisemes; ++v) {
    viseme_names += (v ? ", " : "") + std::string(lipsync::VisemeName(static_cast<lipsync::Viseme>(v)));
  }
  f->SetAttribute(group + "/visemes", "names", viseme_names);
}

}  // namespace facecap::stages
