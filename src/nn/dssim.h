// The structural dissimilarity term of the reconstruction losses: (1 - SSIM) / 2 over 7 x 7
// windows (fewer where the image is smaller), averaged over every window, channel and image.
// Declared on at::Tensor without torch's headers; callers include them.
#ifndef FACECAP_NN_DSSIM_H_
#define FACECAP_NN_DSSIM_H_

namespace at {
class Tensor;
}  // namespace at

namespace facecap::nn {

// x and y: [B, C, H, W] float images in [0, 1]; a differentiable scalar.
at::Tensor Dssim(const at::Tensor& x, const at::Tensor& y);

}  // namespace facecap::nn

#endif  // FACECAP_NN_DSSIM_H_
