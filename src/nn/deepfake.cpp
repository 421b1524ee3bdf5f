// The deepfake's networks and trainer: with nn/dssim.cpp, the translation units of the deepfake
// that include torch (they take a while to compile).
#include "nn/deepfake.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "nn/dssim.h"
#include "util/errors.h"
#include "util/hash.h"

namespace facecap::nn {

namespace {

bool IsPowerOfTwo(int v) { return v > 0 && (v & (v - 1)) == 0; }
int Log2(int v) {
  int l = 0;
  while ((1 << l) < v) ++l;
  return l;
}

torch::nn::LeakyReLU Leaky(double slope) {
  return torch::nn::LeakyReLU(torch::nn::LeakyReLUOptions().negative_slope(slope));
}

torch::nn::Conv2d Conv(int in, int out, int kernel, int stride, int padding) {
  return torch::nn::Conv2d(torch::nn::Conv2dOptions(in, out, kernel).stride(stride).padding(padding));
}

// E: strided 5x5 convolutions from size down to latent_resolution, channels encoder_width,
// 2x, 4x, ..., then a 1x1 convolution to the latent_channels of the code E(I) (no activation).
// forward() returns every level's features (after the activation), then with
// input_skip_width > 0 the features of a stride-1 3x3 convolution of the image, and the code last.
struct EncoderNetImpl : torch::nn::Module {
  explicit EncoderNetImpl(const DeepfakeNetworkOptions& o) {
    const int levels = Log2(o.size / o.latent_resolution);
    int in = 3;
    for (int l = 0; l < levels; ++l) {
      const int out = o.encoder_width << l;
      down.push_back(register_module("down" + std::to_string(l), Conv(in, out, 5, 2, 2)));
      in = out;
    }
    code = register_module("code", Conv(in, o.latent_channels, 1, 1, 0));
    if (o.input_skip_width > 0) full = register_module("full", Conv(3, o.input_skip_width, 3, 1, 1));
  }
  std::vector<torch::Tensor> forward(torch::Tensor x) {
    std::vector<torch::Tensor> out;
    const torch::Tensor image = x;
    for (auto& conv : down) {
      x = torch::leaky_relu(conv->forward(x), 0.1);
      out.push_back(x);
    }
    if (full) out.push_back(torch::leaky_relu(full->forward(image), 0.1));
    out.push_back(code->forward(x));
    return out;
  }
  std::vector<torch::nn::Conv2d> down;
  torch::nn::Conv2d code{nullptr}, full{nullptr};
};
TORCH_MODULE(EncoderNet);

// D_A, D_B: a 3x3 convolution from the code, then per level a nearest 2x upsampling and a 3x3
// convolution (channels halving down to decoder_width), and a 3x3 convolution to RGB in [0, 1]
// or, with a palette head (`colors` > 0), to per-pixel logits over the palette's colours.
// With skips > 0, the upsampled features of the `skips` finest encoder levels are concatenated
// with the encoder's features of the same resolution before the convolution (a U-Net); with
// input_skip_width > 0, the last one also gets the encoder's input-resolution features.
// `width` is the channels of the last level (decoder_width for D_A, decoder_b_width for D_B).
struct DecoderNetImpl : torch::nn::Module {
  DecoderNetImpl(const DeepfakeNetworkOptions& o, int width, int colors = 0)
      : levels(Log2(o.size / o.latent_resolution)), skips(o.skips), colors(colors),
        input_skip(o.input_skip_width > 0) {
    int in = width << (levels - 1);
    input = register_module("in", Conv(o.latent_channels, in, 3, 1, 1));
    for (int l = levels - 1; l >= 0; --l) {
      const int k = levels - 1 - l;
      const int out = width << l;
      const int skip_level = levels - 2 - k;  // encoder level of the same resolution
      int extra = skip_level >= 0 && skip_level < skips ? (o.encoder_width << skip_level) : 0;
      if (skip_level == -1) extra = o.input_skip_width;  // the input resolution's level
      up.push_back(register_module("up" + std::to_string(k), Conv(in + extra, out, 3, 1, 1)));
      in = out;
    }
    rgb = register_module("rgb", Conv(in, colors > 0 ? colors : 3, 3, 1, 1));
    // The palette as a 1x1 convolution from K probabilities to RGB (a buffer, not a parameter).
    if (colors > 0) palette = register_buffer("palette", torch::zeros({3, colors, 1, 1}));
  }
  // The image in [0, 1]; with a palette head also its logits [B, K, H, W] in `logits`.
  torch::Tensor forward(const std::vector<torch::Tensor>& encoded, torch::Tensor* logits = nullptr) {
    torch::Tensor x = torch::leaky_relu(input->forward(encoded.back()), 0.1);
    for (int k = 0; k < levels; ++k) {
      x = torch::upsample_nearest2d(x, {x.size(2) * 2, x.size(3) * 2});
      const int skip_level = levels - 2 - k;
      if (skip_level >= 0 && skip_level < skips) x = torch::cat({x, encoded[skip_level]}, 1);
      if (skip_level == -1 && input_skip) x = torch::cat({x, encoded[levels]}, 1);
      x = torch::leaky_relu(up[k]->forward(x), 0.1);
    }
    const torch::Tensor y = rgb->forward(x);
    if (colors == 0) return torch::sigmoid(y);
    if (logits) *logits = y;
    return torch::conv2d(torch::softmax(y, 1), palette);
  }
  // The colour of each pixel's most likely region.
  torch::Tensor Labels(const torch::Tensor& logits) const {
    const torch::Tensor onehot =
        torch::zeros_like(logits).scatter_(1, logits.argmax(1, true), 1.0);
    return torch::conv2d(onehot, palette);
  }
  int levels, skips, colors;
  bool input_skip;
  torch::Tensor palette;
  torch::nn::Conv2d input{nullptr}, rgb{nullptr};
  std::vector<torch::nn::Conv2d> up;
};
TORCH_MODULE(DecoderNet);

// G_image: a PatchGAN, one score per patch (least-squares GAN: no sigmoid).
torch::nn::Sequential MakeImageDiscriminator(const DeepfakeNetworkOptions& o) {
  torch::nn::Sequential seq;
  const int w = o.discriminator_width;
  seq->push_back("conv0", Conv(3, w, 4, 2, 1));
  seq->push_back("act0", Leaky(0.2));
  seq->push_back("conv1", Conv(w, 2 * w, 4, 2, 1));
  seq->push_back("act1", Leaky(0.2));
  seq->push_back("score", Conv(2 * w, 1, 3, 1, 1));
  return seq;
}

// G_latent: one score per position of the spatial code.
torch::nn::Sequential MakeLatentDiscriminator(const DeepfakeNetworkOptions& o) {
  torch::nn::Sequential seq;
  const int w = o.discriminator_width;
  seq->push_back("conv0", Conv(o.latent_channels, w, 3, 1, 1));
  seq->push_back("act0", Leaky(0.2));
  seq->push_back("conv1", Conv(w, w, 3, 1, 1));
  seq->push_back("act1", Leaky(0.2));
  seq->push_back("score", Conv(w, 1, 1, 1, 0));
  return seq;
}

// uint8 NHWC -> float NCHW in [0, 1] on `device`.
torch::Tensor FromBytes(const uint8_t* images, int count, int size, const torch::Device& device) {
  torch::Tensor t = torch::from_blob(const_cast<uint8_t*>(images), {count, size, size, 3},
                                     torch::kUInt8);
  return t.permute({0, 3, 1, 2}).to(torch::kFloat32).div(255.0).contiguous().to(device);
}

torch::Tensor FromFloats(const std::vector<float>& images, int count, int size,
                         const torch::Device& device) {
  torch::Tensor t = torch::from_blob(const_cast<float*>(images.data()), {count, size, size, 3},
                                     torch::kFloat32);
  return t.permute({0, 3, 1, 2}).contiguous().to(device);
}

// float NCHW in [0, 1] -> uint8 NHWC on the host.
torch::Tensor ToBytes(const torch::Tensor& images) {
  return images.detach().clamp(0, 1).mul(255.0).round().to(torch::kUInt8)
      .permute({0, 2, 3, 1}).contiguous().to(torch::kCPU);
}

}  // namespace

bool DeepfakeNetworkOptions::Check(std::string* why) const {
  if (!IsPowerOfTwo(size) || size < 16 || size > 1024) {
    *why = "size must be a power of two in [16, 1024], got " + std::to_string(size);
    return false;
  }
  if (!IsPowerOfTwo(latent_resolution) || latent_resolution >= size || latent_resolution < 1) {
    *why = "latent_resolution must be a power of two smaller than size";
    return false;
  }
  if (encoder_width < 1 || decoder_width < 1 || discriminator_width < 1 || latent_channels < 1) {
    *why = "encoder_width, decoder_width, discriminator_width and latent_channels must be positive";
    return false;
  }
  if (input_skip_width < 0 || input_skip_width > 1024) {
    *why = "input_skip_width must be in [0, 1024]";
    return false;
  }
  if (palette_colors < 0 || palette_colors == 1 || palette_colors > 256) {
    *why = "palette_colors must be 0 (an RGB head) or in [2, 256]";
    return false;
  }
  if (decoder_b_width < 0) {
    *why = "decoder_b_width must be 0 (decoder_width) or positive";
    return false;
  }
  const int levels = Log2(size / latent_resolution);
  if (skips < 0 || skips > levels - 1) {
    *why = "skips must be in [0, " + std::to_string(levels - 1) + "] for this size and latent_resolution";
    return false;
  }
  if ((static_cast<int64_t>(encoder_width) << levels) > 65536 ||
      (static_cast<int64_t>(std::max(decoder_width, decoder_b_width)) << levels) > 65536) {
    *why = "encoder_width or a decoder width is too large for this many levels";
    return false;
  }
  return true;
}

bool DeepfakeLossOptions::Check(std::string* why) const {
  for (float w : {l1_weight, l2_weight, dssim_weight, image_gan_weight, latent_gan_weight, palette_weight,
                   region_l1_weight, dice_weight}) {
    if (!(w >= 0)) { *why = "loss weights must be >= 0"; return false; }
  }
  if (!(gradient_clip >= 0)) {
    *why = "gradient_clip must be >= 0 (0: no cap)";
    return false;
  }
  if (l1_weight + l2_weight + dssim_weight <= 0) {
    *why = "at least one of l1_weight, l2_weight, dssim_weight must be positive";
    return false;
  }
  if (!(palette_temperature > 0)) {
    *why = "palette_temperature must be positive";
    return false;
  }
  if (!(learning_rate > 0) || !(discriminator_learning_rate > 0)) {
    *why = "learning rates must be positive";
    return false;
  }
  if (!(beta1 >= 0 && beta1 < 1) || !(beta2 >= 0 && beta2 < 1)) {
    *why = "beta1 and beta2 must be in [0, 1)";
    return false;
  }
  return true;
}

void DeepfakeLosses::ToArray(double* v) const {
  v[0] = recon_a; v[1] = recon_b; v[2] = image_adversarial; v[3] = latent_adversarial;
  v[4] = image_discriminator; v[5] = latent_discriminator; v[6] = palette_a; v[8] = dice_a;
  v[7] = region_l1_a;
}
void DeepfakeLosses::FromArray(const double* v) {
  recon_a = v[0]; recon_b = v[1]; image_adversarial = v[2]; latent_adversarial = v[3];
  image_discriminator = v[4]; latent_discriminator = v[5]; palette_a = v[6]; dice_a = v[8];
  region_l1_a = v[7];
}

void UpdateMovingAverage(const float* weights, int64_t count, int64_t steps_done, double decay,
                         float* averaged) {
  const double warm = (1.0 + static_cast<double>(steps_done)) / (10.0 + static_cast<double>(steps_done));
  const float d = static_cast<float>(std::min(decay, warm));
  for (int64_t i = 0; i < count; ++i) averaged[i] = d * averaged[i] + (1.f - d) * weights[i];
}

void SetTorchThreads(int threads) {
  torch::set_num_threads(std::max(1, threads));
  static bool interop_set = false;  // may be set once, before any parallel work
  if (!interop_set) {
    interop_set = true;
    try { torch::set_num_interop_threads(1); } catch (const std::exception&) {}
  }
}

bool CudaAvailable() { return torch::cuda::is_available(); }

// ---------------------------------------------------------------------------------------------

struct DeepfakeModel::Impl {
  DeepfakeNetworkOptions options;
  torch::Device device = torch::kCPU;
  EncoderNet encoder{nullptr};
  DecoderNet decoder_a{nullptr}, decoder_b{nullptr};
  torch::nn::Sequential image_discriminator{nullptr}, latent_discriminator{nullptr};
  std::vector<torch::Tensor> parameters;  // views into `flat`, in layout order
  std::vector<TensorSlot> layout;
  int64_t generator_count = 0;  // E, D_A, D_B come first in the buffers
  torch::Tensor flat;           // every parameter, on the device
  torch::Tensor host;           // host mirror of `flat` (only when the device is not the CPU)
  torch::Tensor mirror;         // palette index of each colour's mirror (SetFlipAverage)
  int shift_average = 0;        // SetShiftAverage
  int label_scale = 1;          // SetLabelScale

  bool on_cpu() const { return device.is_cpu(); }
  float* host_data() { return on_cpu() ? flat.data_ptr<float>() : host.data_ptr<float>(); }

  template <class Net>
  void Collect(const std::string& prefix, const Net& net) {
    for (const auto& item : net->named_parameters()) {
      std::string name = prefix + "/" + item.key();
      for (char& c : name) if (c == '.') c = '/';
      TensorSlot slot;
      slot.name = name;
      slot.shape = item.value().sizes().vec();
      slot.count = item.value().numel();
      layout.push_back(slot);
      parameters.push_back(item.value());
    }
  }
};

DeepfakeModel::DeepfakeModel(const DeepfakeNetworkOptions& options, uint64_t init_seed,
                             const std::string& device)
    : impl_(std::make_unique<Impl>()) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError("deepfake network: " + why);
  Impl& m = *impl_;
  m.options = options;
  if (device == "cuda") {
    if (!torch::cuda::is_available()) {
      throw InvalidInputError("device cuda: this libtorch has no CUDA or no GPU is visible; use "
                              "--device cpu");
    }
    m.device = torch::Device(torch::kCUDA);
  } else if (device != "cpu") {
    throw InvalidInputError("device must be cpu or cuda, got '" + device + "'");
  }
  torch::manual_seed(init_seed);
  m.encoder = EncoderNet(options);
  m.decoder_a = DecoderNet(options, options.decoder_width, options.palette_colors);
  m.decoder_b = DecoderNet(options, options.decoder_b_width > 0 ? options.decoder_b_width
                                                                : options.decoder_width);
  m.image_discriminator = MakeImageDiscriminator(options);
  m.latent_discriminator = MakeLatentDiscriminator(options);
  m.encoder->to(m.device);
  m.decoder_a->to(m.device);
  m.decoder_b->to(m.device);
  m.image_discriminator->to(m.device);
  m.latent_discriminator->to(m.device);
  m.Collect("encoder", m.encoder);
  m.Collect("decoder_a", m.decoder_a);
  m.Collect("decoder_b", m.decoder_b);
  m.generator_count = 0;
  for (const auto& s : m.layout) m.generator_count += s.count;
  m.Collect("image_discriminator", m.image_discriminator);
  m.Collect("latent_discriminator", m.latent_discriminator);
  int64_t total = 0;
  for (auto& s : m.layout) {
    s.offset = total;
    total += s.count;
  }
  // Move every parameter into one contiguous buffer; the parameters become views of it.
  torch::NoGradGuard no_grad;
  m.flat = torch::empty({total}, torch::TensorOptions().dtype(torch::kFloat32).device(m.device));
  for (size_t i = 0; i < m.parameters.size(); ++i) {
    torch::Tensor view = m.flat.narrow(0, m.layout[i].offset, m.layout[i].count)
                             .view(m.parameters[i].sizes());
    view.copy_(m.parameters[i]);
    m.parameters[i].set_data(view);
  }
  if (!m.on_cpu()) m.host = m.flat.to(torch::kCPU).contiguous();
}

DeepfakeModel::~DeepfakeModel() = default;

const DeepfakeNetworkOptions& DeepfakeModel::options() const { return impl_->options; }
const std::vector<TensorSlot>& DeepfakeModel::ParameterLayout() const { return impl_->layout; }
int64_t DeepfakeModel::num_parameters() const { return impl_->flat.numel(); }
float* DeepfakeModel::parameters() { return impl_->host_data(); }

void DeepfakeModel::ParametersWritten() {
  if (!impl_->on_cpu()) {
    torch::NoGradGuard no_grad;
    impl_->flat.copy_(impl_->host);
  }
}

void DeepfakeModel::ParametersToHost() {
  if (!impl_->on_cpu()) impl_->host.copy_(impl_->flat);
}

void DeepfakeModel::SetPalette(const std::vector<float>& colors) {
  const int k = impl_->options.palette_colors;
  if (k == 0) return;
  if (colors.size() != 3 * static_cast<size_t>(k)) {
    throw InvalidInputError("deepfake: the palette head has " + std::to_string(k) +
                            " colours, the palette given has " + std::to_string(colors.size() / 3));
  }
  torch::NoGradGuard no_grad;
  const torch::Tensor c = torch::tensor(colors, torch::kFloat32).view({k, 3});
  impl_->decoder_a->palette.copy_(c.t().reshape({3, k, 1, 1}).to(impl_->device));
}

void DeepfakeModel::SetFlipAverage(const std::vector<int>& mirror) {
  const int k = impl_->options.palette_colors;
  if (mirror.empty()) {
    impl_->mirror = torch::Tensor();
    return;
  }
  if (static_cast<int>(mirror.size()) != k) {
    throw InvalidInputError("deepfake: flip averaging needs a mirror index for each of the palette "
                            "head's " + std::to_string(k) + " colours, got " +
                            std::to_string(mirror.size()));
  }
  std::vector<int64_t> index(mirror.begin(), mirror.end());
  for (int64_t i : index) {
    if (i < 0 || i >= k) throw InvalidInputError("deepfake: a mirror index is out of range");
  }
  impl_->mirror = torch::tensor(index, torch::kInt64).to(impl_->device);
}

void DeepfakeModel::SetShiftAverage(int pixels) {
  if (pixels < 0) throw InvalidInputError("deepfake: the shift of shift averaging must be >= 0");
  impl_->shift_average = pixels;
}

void DeepfakeModel::SetLabelScale(int scale) {
  if (scale < 1 || scale > 4) {
    throw InvalidInputError("deepfake: the label scale must be 1-4, got " + std::to_string(scale));
  }
  impl_->label_scale = scale;
}

int DeepfakeModel::TranslationSize(Decoder decoder) const {
  const bool labels = decoder == Decoder::kA && impl_->options.palette_colors > 0;
  return impl_->options.size * (labels ? impl_->label_scale : 1);
}

uint64_t DeepfakeModel::ParameterHash() {
  ParametersToHost();
  const auto* bytes = reinterpret_cast<const uint8_t*>(parameters());
  const size_t n = static_cast<size_t>(num_parameters()) * sizeof(float);
  return Fnv1a(bytes, n);
}

void DeepfakeModel::Translate(const uint8_t* images, int count, Decoder decoder,
                              uint8_t* translated, float* code, float* code_of_translation) {
  if (count <= 0) return;
  Impl& m = *impl_;
  torch::NoGradGuard no_grad;
  const int size = m.options.size;
  const torch::Tensor x = FromBytes(images, count, size, m.device);
  const std::vector<torch::Tensor> encoded = m.encoder->forward(x);
  const torch::Tensor& z = encoded.back();
  torch::Tensor y, y_out;  // the translation at the network's size, and as returned
  if (decoder == DeepfakeModel::Decoder::kB) {
    y = m.decoder_b->forward(encoded);
  } else if (m.options.palette_colors == 0) {
    y = m.decoder_a->forward(encoded);
  } else {
    // D_A's region log-probabilities of the image moved by (dx, dy) pixels (edges repeated),
    // moved back, and with the mirror image's, mirrored back with left and right swapped.
    auto log_probabilities = [&](int dx, int dy) {
      auto moved = [&](const torch::Tensor& t, int sx, int sy) {
        if (sx == 0 && sy == 0) return t;
        namespace F = torch::nn::functional;
        const torch::Tensor padded = F::pad(
            t, F::PadFuncOptions({std::max(sx, 0), std::max(-sx, 0), std::max(sy, 0), std::max(-sy, 0)})
                   .mode(torch::kReplicate));
        return padded.slice(2, std::max(-sy, 0), std::max(-sy, 0) + size)
            .slice(3, std::max(-sx, 0), std::max(-sx, 0) + size);
      };
      const torch::Tensor xs = moved(x, dx, dy);
      torch::Tensor logits;
      if (dx == 0 && dy == 0) {
        m.decoder_a->forward(encoded, &logits);
      } else {
        m.decoder_a->forward(m.encoder->forward(xs), &logits);
      }
      if (!m.mirror.defined() && m.shift_average == 0) {
        return logits;  // a single pass
      }
      torch::Tensor sum = torch::log_softmax(moved(logits, -dx, -dy), 1);
      if (m.mirror.defined()) {
        torch::Tensor mirrored;
        m.decoder_a->forward(m.encoder->forward(xs.flip({3})), &mirrored);
        sum += torch::log_softmax(moved(mirrored.flip({3}), -dx, -dy).index_select(1, m.mirror), 1);
      }
      return sum;
    };
    torch::Tensor sum = log_probabilities(0, 0);
    const int d = m.shift_average;
    if (d > 0) {
      for (int dy = -d; dy <= d; dy += d) {
        for (int dx = -d; dx <= d; dx += d) {
          if (dx != 0 || dy != 0) sum += log_probabilities(dx, dy);
        }
      }
    }
    y = m.decoder_a->Labels(sum);
    if (m.label_scale > 1) {
      const int64_t side = static_cast<int64_t>(size) * m.label_scale;
      y_out = m.decoder_a->Labels(torch::upsample_bilinear2d(sum, {side, side}, false));
    }
  }
  if (!y_out.defined()) y_out = y;
  const int64_t latent = m.options.LatentSize();
  if (translated) {
    const torch::Tensor bytes = ToBytes(y_out);
    std::memcpy(translated, bytes.data_ptr<uint8_t>(), static_cast<size_t>(bytes.numel()));
  }
  if (code) {
    const torch::Tensor c = z.reshape({count, latent}).contiguous().to(torch::kCPU);
    std::memcpy(code, c.data_ptr<float>(), sizeof(float) * count * latent);
  }
  if (code_of_translation) {
    // E(D(E(I))) of the translation at the network's size, quantized to 8 bits as stored.
    const torch::Tensor yq = y.clamp(0, 1).mul(255.0).round().div(255.0);
    const torch::Tensor c =
        m.encoder->forward(yq).back().reshape({count, latent}).contiguous().to(torch::kCPU);
    std::memcpy(code_of_translation, c.data_ptr<float>(), sizeof(float) * count * latent);
  }
}

// ---------------------------------------------------------------------------------------------

struct DeepfakeTrainer::Impl {
  DeepfakeModel* model = nullptr;
  DeepfakeLossOptions losses;
  torch::Tensor gradients;        // on the device, layout of the model
  torch::Tensor gradients_host;   // host mirror (device other than the CPU)
  torch::Tensor first_moment, second_moment;            // Adam m, v on the device
  torch::Tensor first_moment_host, second_moment_host;  // host mirrors
  std::vector<torch::Tensor> gradient_views;
  int64_t step = 0;
  torch::Tensor palette, palette_weights;  // [K, 3] and [K] on the device (SetPalette)

  DeepfakeModel::Impl& m() { return *model->impl_; }
  bool on_cpu() { return m().on_cpu(); }

  // Points every parameter's .grad at its slice of the gradient buffer.
  void AttachGradients() {
    auto& params = m().parameters;
    gradient_views.clear();
    for (size_t i = 0; i < params.size(); ++i) {
      const TensorSlot& s = m().layout[i];
      torch::Tensor view = gradients.narrow(0, s.offset, s.count).view(params[i].sizes());
      params[i].mutable_grad() = view;
      gradient_views.push_back(view);
    }
  }
  // Autograd accumulates into an existing .grad in place; should it ever have replaced one,
  // copy the result into the buffer and attach the view again.
  void GatherGradients() {
    auto& params = m().parameters;
    torch::NoGradGuard no_grad;
    for (size_t i = 0; i < params.size(); ++i) {
      const torch::Tensor& g = params[i].grad();
      if (!g.defined()) {
        gradient_views[i].zero_();
      } else if (g.data_ptr() != gradient_views[i].data_ptr()) {
        gradient_views[i].copy_(g);
      }
      params[i].mutable_grad() = gradient_views[i];
    }
  }
};

DeepfakeTrainer::DeepfakeTrainer(DeepfakeModel* model, const DeepfakeLossOptions& losses)
    : impl_(std::make_unique<Impl>()) {
  std::string why;
  if (!losses.Check(&why)) throw InvalidInputError("deepfake losses: " + why);
  Impl& t = *impl_;
  t.model = model;
  t.losses = losses;
  const auto& flat = t.m().flat;
  t.gradients = torch::zeros_like(flat);
  t.first_moment = torch::zeros_like(flat);
  t.second_moment = torch::zeros_like(flat);
  if (!t.on_cpu()) {
    t.gradients_host = torch::zeros({flat.numel()}, torch::kFloat32);
    t.first_moment_host = torch::zeros({flat.numel()}, torch::kFloat32);
    t.second_moment_host = torch::zeros({flat.numel()}, torch::kFloat32);
  }
  t.AttachGradients();
}

DeepfakeTrainer::~DeepfakeTrainer() = default;

DeepfakeModel& DeepfakeTrainer::model() { return *impl_->model; }
float* DeepfakeTrainer::gradients() {
  return impl_->on_cpu() ? impl_->gradients.data_ptr<float>()
                         : impl_->gradients_host.data_ptr<float>();
}
int64_t DeepfakeTrainer::num_gradients() const { return impl_->gradients.numel(); }
float* DeepfakeTrainer::first_moments() {
  return impl_->on_cpu() ? impl_->first_moment.data_ptr<float>()
                         : impl_->first_moment_host.data_ptr<float>();
}
float* DeepfakeTrainer::second_moments() {
  return impl_->on_cpu() ? impl_->second_moment.data_ptr<float>()
                         : impl_->second_moment_host.data_ptr<float>();
}
int64_t DeepfakeTrainer::step() const { return impl_->step; }
void DeepfakeTrainer::set_step(int64_t step) { impl_->step = step; }

void DeepfakeTrainer::OptimizerStateWritten() {
  if (!impl_->on_cpu()) {
    impl_->first_moment.copy_(impl_->first_moment_host);
    impl_->second_moment.copy_(impl_->second_moment_host);
  }
}
void DeepfakeTrainer::OptimizerStateToHost() {
  if (!impl_->on_cpu()) {
    impl_->first_moment_host.copy_(impl_->first_moment);
    impl_->second_moment_host.copy_(impl_->second_moment);
  }
}

DeepfakeLosses DeepfakeTrainer::Backward(const TrainingBatch& batch, double share) {
  Impl& t = *impl_;
  DeepfakeModel::Impl& m = t.m();
  const DeepfakeLossOptions& w = t.losses;
  if (batch.size != m.options.size) {
    throw InvalidInputError("deepfake: batch images are " + std::to_string(batch.size) +
                            " pixels, the network takes " + std::to_string(m.options.size));
  }
  {
    torch::NoGradGuard no_grad;
    t.gradients.zero_();
  }
  DeepfakeLosses out;
  if (batch.count > 0) {
    const torch::Tensor input_a = FromFloats(batch.input_a, batch.count, batch.size, m.device);
    const torch::Tensor target_a = FromFloats(batch.target_a, batch.count, batch.size, m.device);
    const torch::Tensor input_b = FromFloats(batch.input_b, batch.count, batch.size, m.device);
    const torch::Tensor target_b = FromFloats(batch.target_b, batch.count, batch.size, m.device);

    const std::vector<torch::Tensor> encoded_a = m.encoder->forward(input_a);
    const std::vector<torch::Tensor> encoded_b = m.encoder->forward(input_b);
    const torch::Tensor& code_a = encoded_a.back();                // E(I_A)
    const torch::Tensor& code_b = encoded_b.back();                // E(I_B)
    torch::Tensor logits_a;                                                     // palette head
    const torch::Tensor recon_a = m.decoder_a->forward(encoded_a, &logits_a);  // D_A(E(I_A))
    const torch::Tensor recon_b = m.decoder_b->forward(encoded_b);  // D_B(E(I_B))

    auto reconstruction = [&](const torch::Tensor& y, const torch::Tensor& x) {
      torch::Tensor loss = torch::zeros({}, y.options());
      if (w.l1_weight > 0) loss = loss + w.l1_weight * (y - x).abs().mean();
      if (w.l2_weight > 0) loss = loss + w.l2_weight * (y - x).pow(2).mean();
      if (w.dssim_weight > 0) loss = loss + w.dssim_weight * Dssim(y, x);
      return loss;
    };
    // f_recon = ||D_A(E(I_A)) - I_A|| + ||D_B(E(I_B)) - I_B||
    const torch::Tensor recon_loss_a = reconstruction(recon_a, target_a);
    // The palette term: the weighted cross-entropy of each pixel's target region (its nearest
    // palette colour) under logits -|y - c_k|^2 / T, a weighted mean over the pixels; the
    // region-weighted L1 term: |y - x| with the same pixel weights.
    torch::Tensor palette_loss = torch::zeros({}, recon_a.options());
    torch::Tensor region_l1_loss = torch::zeros({}, recon_a.options());
    torch::Tensor dice_loss = torch::zeros({}, recon_a.options());
    if ((w.palette_weight > 0 || w.region_l1_weight > 0 || w.dice_weight > 0) && t.palette.defined()) {
      // [B, 3, H, W] -> [B, K, H, W]: |y - c_k|^2 = |y|^2 - 2 y.c_k + |c_k|^2, the middle
      // term a 1x1 convolution (no [B, K, 3, H, W] intermediate to build and differentiate).
      const torch::Tensor palette_norms = t.palette.pow(2).sum(1).view({1, -1, 1, 1});
      auto distances = [&](const torch::Tensor& images) {
        const torch::Tensor dot = torch::conv2d(images, t.palette.view({-1, 3, 1, 1}));
        return images.pow(2).sum(1, true) - 2 * dot + palette_norms;
      };
      torch::Tensor labels, pixel_weights;
      {
        torch::NoGradGuard no_grad;
        labels = distances(target_a).argmin(1);                       // [B, H, W]
        pixel_weights = t.palette_weights.index({labels});            // [B, H, W]
      }
      const torch::Tensor logits =
          logits_a.defined() ? logits_a : -distances(recon_a) / w.palette_temperature;
      if (w.palette_weight > 0) {
        const torch::Tensor log_p = torch::log_softmax(logits, 1);
        const torch::Tensor nll = -log_p.gather(1, labels.unsqueeze(1)).squeeze(1);
        palette_loss = (nll * pixel_weights).mean();
      }
      if (w.dice_weight > 0) {
        const torch::Tensor p = torch::softmax(logits, 1);                          // [B, K, H, W]
        const torch::Tensor onehot = torch::zeros_like(p).scatter_(1, labels.unsqueeze(1), 1.0);
        const torch::Tensor overlap = (p * onehot).sum({2, 3});                     // [B, K]
        const torch::Tensor total = p.sum({2, 3}) + onehot.sum({2, 3});
        dice_loss = (1.0 - (2.0 * overlap + 1.0) / (total + 1.0)).mean();
      }
      if (w.region_l1_weight > 0) {
        region_l1_loss = ((recon_a - target_a).abs() * pixel_weights.unsqueeze(1)).mean();
      }
    }
    const torch::Tensor recon_loss_b = reconstruction(recon_b, target_b);
    // The generators' side of the asymmetric GAN losses (least squares): D_A maximizes f_image
    // by pushing G_image(D_A(E(I_A))) to 1; E maximizes f_latent by pushing G_latent(E(I_B))
    // to 1, the score of codes of A, so that B's codes land where D_A can decode them.
    // With image_gan_weight 0, G_image is neither evaluated nor trained (f_image reads 0).
    const bool image_gan = w.image_gan_weight > 0;
    const torch::Tensor image_adversarial =
        image_gan ? (1.0 - m.image_discriminator->forward(recon_a)).pow(2).mean()
                  : torch::zeros({}, recon_a.options());
    const torch::Tensor latent_adversarial =
        (1.0 - m.latent_discriminator->forward(code_b)).pow(2).mean();
    const torch::Tensor generator_loss =
        (recon_loss_a + recon_loss_b + w.palette_weight * palette_loss + w.region_l1_weight * region_l1_loss +
         w.dice_weight * dice_loss + w.image_gan_weight * image_adversarial +
         w.latent_gan_weight * latent_adversarial) * share;
    generator_loss.backward();
    {
      // The discriminators learn only from their own losses below.
      torch::NoGradGuard no_grad;
      t.gradients.narrow(0, m.generator_count, t.gradients.numel() - m.generator_count).zero_();
    }
    // f_image = ||G_image(D_A(E(I_A)))|| + ||1 - G_image(I_A)||
    const torch::Tensor image_discriminator =
        image_gan ? m.image_discriminator->forward(recon_a.detach()).pow(2).mean() +
                        (1.0 - m.image_discriminator->forward(target_a)).pow(2).mean()
                  : torch::zeros({}, recon_a.options());
    // f_latent = ||G_latent(E(I_B))|| + ||1 - G_latent(E(I_A))||
    const torch::Tensor latent_discriminator =
        m.latent_discriminator->forward(code_b.detach()).pow(2).mean() +
        (1.0 - m.latent_discriminator->forward(code_a.detach())).pow(2).mean();
    ((image_discriminator + latent_discriminator) * share).backward();
    t.GatherGradients();

    out.recon_a = recon_loss_a.item<double>() * share;
    out.recon_b = recon_loss_b.item<double>() * share;
    out.image_adversarial = image_adversarial.item<double>() * share;
    out.latent_adversarial = latent_adversarial.item<double>() * share;
    out.image_discriminator = image_discriminator.item<double>() * share;
    out.latent_discriminator = latent_discriminator.item<double>() * share;
    out.palette_a = palette_loss.item<double>() * share;
    out.region_l1_a = region_l1_loss.item<double>() * share;
    out.dice_a = dice_loss.item<double>() * share;
  }
  if (!t.on_cpu()) t.gradients_host.copy_(t.gradients);
  return out;
}

void DeepfakeTrainer::SetPalette(const std::vector<float>& colors, const std::vector<float>& weights) {
  if (colors.size() != 3 * weights.size() || weights.empty()) {
    throw InvalidInputError("deepfake: the palette needs 3 colour values and one weight per region");
  }
  const torch::Device device = impl_->m().device;
  impl_->palette = torch::tensor(colors, torch::kFloat32).view({-1, 3}).to(device);
  impl_->palette_weights = torch::tensor(weights, torch::kFloat32).to(device);
}

void DeepfakeTrainer::OptimizerStep(double learning_rate_scale) {
  Impl& t = *impl_;
  DeepfakeModel::Impl& m = t.m();
  torch::NoGradGuard no_grad;
  if (!t.on_cpu()) t.gradients.copy_(t.gradients_host);
  ++t.step;
  const double b1 = t.losses.beta1, b2 = t.losses.beta2, eps = 1e-8;
  const double bias1 = 1.0 - std::pow(b1, static_cast<double>(t.step));
  const double bias2 = 1.0 - std::pow(b2, static_cast<double>(t.step));
  const int64_t n = m.flat.numel(), g = m.generator_count;
  // Adam, the generators (E, D_A, D_B) and the discriminators with their own learning rates.
  for (const auto& [begin, count, lr] :
       {std::tuple<int64_t, int64_t, double>{0, g, t.losses.learning_rate * learning_rate_scale},
        std::tuple<int64_t, int64_t, double>{g, n - g,
                                             t.losses.discriminator_learning_rate * learning_rate_scale}}) {
    if (count == 0) continue;
    torch::Tensor p = m.flat.narrow(0, begin, count);
    torch::Tensor grad = t.gradients.narrow(0, begin, count);
    torch::Tensor mom1 = t.first_moment.narrow(0, begin, count);
    torch::Tensor mom2 = t.second_moment.narrow(0, begin, count);
    if (t.losses.gradient_clip > 0 && t.step > 1) {
      // ||g|| against the RMS norm of the gradients so far, sqrt(sum of v / (1 - b2^(k-1))).
      const double seen = mom2.sum().item<double>() / (1.0 - std::pow(b2, t.step - 1.0));
      const double norm = grad.norm().item<double>();
      const double cap = t.losses.gradient_clip * std::sqrt(seen);
      if (cap > 0 && norm > cap) grad.mul_(cap / norm);
    }
    mom1.mul_(b1).add_(grad, 1.0 - b1);
    mom2.mul_(b2).addcmul_(grad, grad, 1.0 - b2);
    const torch::Tensor denominator = (mom2.sqrt() / std::sqrt(bias2)).add_(eps);
    p.addcdiv_(mom1, denominator, -lr / bias1);
  }
  if (!t.on_cpu()) m.host.copy_(m.flat);
}

Image8 DeepfakeTrainer::PreviewGrid(const uint8_t* images_a, const uint8_t* images_b, int count) {
  DeepfakeModel::Impl& m = impl_->m();
  const int s = m.options.size;
  Image8 grid(5 * s, std::max(1, count) * s, 3);
  if (count <= 0) return grid;
  torch::NoGradGuard no_grad;
  const torch::Tensor xa = FromBytes(images_a, count, s, m.device);
  const torch::Tensor xb = FromBytes(images_b, count, s, m.device);
  const std::vector<torch::Tensor> encoded_b = m.encoder->forward(xb);
  const std::vector<torch::Tensor> columns = {
      xa, m.decoder_a->forward(m.encoder->forward(xa)), xb, m.decoder_b->forward(encoded_b),
      m.decoder_a->forward(encoded_b)};
  for (int c = 0; c < 5; ++c) {
    const torch::Tensor bytes = ToBytes(columns[c]);
    const uint8_t* p = bytes.data_ptr<uint8_t>();
    for (int i = 0; i < count; ++i) {
      for (int y = 0; y < s; ++y) {
        std::memcpy(grid.pixel(c * s, i * s + y), p + (static_cast<size_t>(i) * s + y) * s * 3,
                    static_cast<size_t>(s) * 3);
      }
    }
  }
  return grid;
}

}  // namespace facecap::nn
