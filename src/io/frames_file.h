// The names of the per-frame datasets, one row per frame (N frames), of the files that hold
// frames: an ingest output (frames.h5: IngestedFrames reads it), deepfake infer's translations
// (translations_file.h reads them), a synthetic clip (synth clip, synth crops; clip_file.h
// reads its truth) and appearance's turntables and tracked views.
// Each comment says which files hold the dataset, its shape, type and units; the camera the
// images were taken with is camera_file.h's.
#ifndef FACECAP_IO_FRAMES_FILE_H_
#define FACECAP_IO_FRAMES_FILE_H_

namespace facecap::io::frames {

// Images, [N, H, W, 3] uint8 RGB, row-major from the top-left pixel.
inline constexpr char kImage[] = "/frames/image";                // clip, turntable: the frame
inline constexpr char kCrop[] = "/frames/crop";                  // ingest: square aligned crop
inline constexpr char kSegmentation[] = "/frames/segmentation";  // clip, crops: region colours
inline constexpr char kTranslated[] = "/frames/translated";      // translations: D_A(E(I))

// Ingest: what was found in each source frame.
inline constexpr char kFound[] = "/frames/found";          // [N] uint8: 1 the subject's face
                                                           // (translations copy it)
inline constexpr char kStatus[] = "/frames/status";        // [N] int32: IngestFrameStatus
inline constexpr char kInputFlags[] = "/frames/input_flags";  // [N] int32: bits, see ingest
inline constexpr char kImageSize[] = "/frames/image_size";    // [N, 2] int32: width, height px
inline constexpr char kBox[] = "/frames/box";  // [N, 5] float: x, y, w, h (source px), score
// [N, 68, 2] float, iBUG order: ingest's in source pixels (centres at integers), a clip's in
// image pixels.
inline constexpr char kLandmarks[] = "/frames/landmarks";
inline constexpr char kLandmarksCrop[] = "/frames/landmarks_crop";  // ingest: [N, 68, 2] crop px
inline constexpr char kCropTransform[] = "/frames/crop_transform";  // ingest: [N, 2, 3] source
                                                                    // px -> crop px, [s R | t]
inline constexpr char kSourceIndex[] = "/frames/source_index";      // ingest: [N] int64
inline constexpr char kSourceFileId[] = "/frames/source_file_id";   // ingest: [N], row of
                                                                    // /sources/files
inline constexpr char kTimecode[] = "/frames/timecode";  // ingest: [N] float64 s (-1: a still)

// A clip's truth.
inline constexpr char kPose[] = "/frames/pose";                // [N, 3] float: pitch, yaw, roll rad
inline constexpr char kTranslation[] = "/frames/translation";  // [N, 3] float cm
inline constexpr char kWeights[] = "/frames/weights";          // [N, S] float in [0, 1]
inline constexpr char kShapeNames[] = "/frames/shape_names";   // [S] strings
inline constexpr char kLandmarkVisible[] = "/frames/landmark_visible";  // [N, 68] uint8
inline constexpr char kDegradation[] = "/frames/degradation";  // [N, 6] float: the camera's

// Translations: the codes of deepfake infer (sample_file.h names which a sample set uses).
inline constexpr char kLatent[] = "/frames/latent";  // [N, C] float: E(I)
inline constexpr char kLatentOfTranslation[] = "/frames/latent_of_translation";  // E(D_A(E(I)))

// Appearance's views: what each pixel of a view sees of the rig.
inline constexpr char kUv[] = "/frames/uv";              // [N, H, W, 3] float: u, v, coverage
inline constexpr char kTriangle[] = "/frames/triangle";  // [N, H, W] int32, -1 none
inline constexpr char kDepth[] = "/frames/depth";        // [N, H, W] float cm, 0 none
inline constexpr char kCamera[] = "/frames/camera";      // [N, 4] float: fx, fy, cx, cy px

}  // namespace facecap::io::frames

#endif  // FACECAP_IO_FRAMES_FILE_H_
