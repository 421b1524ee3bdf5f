#include "nn/blendshape_generator.h"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <unordered_map>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <torch/torch.h>

#include "nn/adam.h"
#include "nn/parameter_vector.h"
#include "util/errors.h"

namespace facecap::nn {
namespace {

namespace F = torch::nn::functional;

torch::nn::Conv2d Conv(int in, int out, int kernel, int stride = 1) {
  return torch::nn::Conv2d(
      torch::nn::Conv2dOptions(in, out, kernel).stride(stride).padding(kernel == 4 ? 1 : kernel / 2));
}

// Residual block, optionally with instance normalization (the decoder's).
struct ResidualBlockImpl : torch::nn::Module {
  ResidualBlockImpl(int channels, bool instance_norm) : normalize(instance_norm) {
    first = register_module("first", Conv(channels, channels, 3));
    second = register_module("second", Conv(channels, channels, 3));
  }
  torch::Tensor forward(const torch::Tensor& x) {
    torch::Tensor y = first->forward(x);
    if (normalize) y = F::instance_norm(y);
    y = torch::relu(y);
    y = second->forward(y);
    if (normalize) y = F::instance_norm(y);
    return x + y;
  }
  bool normalize;
  torch::nn::Conv2d first{nullptr}, second{nullptr};
};
TORCH_MODULE(ResidualBlock);

// Identity encoder: a few convolutions down to 1/4 resolution, then residual blocks.
struct EncoderImpl : torch::nn::Module {
  EncoderImpl(int in, int c, int blocks) {
    layers = register_module("layers", torch::nn::Sequential());
    layers->push_back(Conv(in, c, 3));
    layers->push_back(torch::nn::ReLU());
    layers->push_back(Conv(c, 2 * c, 4, 2));
    layers->push_back(torch::nn::ReLU());
    layers->push_back(Conv(2 * c, 4 * c, 4, 2));
    layers->push_back(torch::nn::ReLU());
    for (int b = 0; b < blocks; ++b) layers->push_back(ResidualBlock(4 * c, false));
  }
  torch::Tensor forward(const torch::Tensor& x) { return layers->forward(x); }
  torch::nn::Sequential layers{nullptr};
};
TORCH_MODULE(Encoder);

// Blendshape decoder: an instance-normalized residual block, two upscaling convolutions and a
// 1x1 output convolution initialized to zero (the generator starts at the template, eq. 3).
struct DecoderImpl : torch::nn::Module {
  DecoderImpl(int c, int out) {
    block = register_module("block", ResidualBlock(4 * c, true));
    up1 = register_module("up1", Conv(4 * c, 2 * c, 3));
    up2 = register_module("up2", Conv(2 * c, c, 3));
    output = register_module("output", Conv(c, out, 1));
    torch::NoGradGuard no_grad;
    output->weight.zero_();
    output->bias.zero_();
  }
  // The last features at full resolution (c channels), before the output convolution.
  torch::Tensor Features(const torch::Tensor& x) {
    auto upsample = [](const torch::Tensor& t) {
      return F::interpolate(t, F::InterpolateFuncOptions().scale_factor(std::vector<double>{2, 2}).mode(torch::kNearest));
    };
    torch::Tensor y = block->forward(x);
    y = torch::relu(up1->forward(upsample(y)));
    return torch::relu(up2->forward(upsample(y)));
  }
  std::shared_ptr<ResidualBlockImpl> block{nullptr};
  torch::nn::Conv2d up1{nullptr}, up2{nullptr}, output{nullptr};
};
TORCH_MODULE(Decoder);

// Template-conditioned output head of one branch: shape i of the branch at chart vertex x gets
//   |S_i(x)| MLP(f(x), S_i(x) / sigma, |S_i(x)| / sigma)
// added to its offsets, f the decoder's last features and the generator's input (a skip: the
// neutral's geometry there at full resolution) sampled at x, sigma the RMS template motion.
// One MLP serves all the branch's shapes, so a shape's personal motion can depend on its own
// template motion at that point; a 1x1 output convolution alone mixes the same c features into
// every shape with weights that do not vary over the face. The output layer
// starts at zero (the generator still starts at the template). It runs only on the (shape,
// vertex) pairs where the template moves (about a fifth of them); elsewhere it adds nothing.
// With `frame`, the head also works in the frame of the template motion: its hidden layer
// sees the neutral's displacement along the motion, d(x) . S_i(x) / |S_i(x)| (a product that
// a ReLU layer only approximates), and a fourth output is a gain on the template motion
// itself, adding gain S_i(x) (a person moving a point further or less along the same path).
// depth 2 adds a second hidden layer of the same width: one ReLU layer leaves jawOpen's
// personal pattern a few percent of its motion off even on the training people.
// With `local` (frame heads only), the free offset is given in a frame built from the template
// motion and the neutral's displacement d(x) at the point, |S_i(x)| (o_1 S_i(x) / |S_i(x)| +
// o_2 d(x) + o_3 (S_i(x) / |S_i(x)|) x d(x)), and the hidden layer also sees |d(x)|: the head
// then maps scalars that do not change when the face turns (|d|, d . S_i / |S_i|, the
// features) to scalars, instead of building directions out of ReLUs.
struct TemplateHeadImpl : torch::nn::Module {
  // deltas: the branch's template motion S_i(x), [S, A, 3]; sigma: the RMS template motion;
  // displacement: the first of the 3 feature columns that hold the neutral's displacement.
  TemplateHeadImpl(int features, int width, int depth, const torch::Tensor& deltas, double sigma, bool frame,
                   int64_t displacement, bool local)
      : shapes(deltas.size(0)), vertices(deltas.size(1)), frame(frame), local(frame && local), displacement(displacement) {
    from_features = register_module("features", torch::nn::Linear(features, width));
    from_motion = register_module("motion", torch::nn::Linear(torch::nn::LinearOptions(4, width).bias(false)));
    output = register_module("output", torch::nn::Linear(width, frame ? 4 : 3));
    if (frame) from_along = register_module("along", torch::nn::Linear(torch::nn::LinearOptions(1, width).bias(false)));
    if (depth > 1) second = register_module("second", torch::nn::Linear(width, width));
    if (this->local) from_norm = register_module("norm", torch::nn::Linear(torch::nn::LinearOptions(1, width).bias(false)));
    torch::NoGradGuard no_grad;
    output->weight.zero_();
    output->bias.zero_();
    const torch::Tensor flat = deltas.reshape({shapes * vertices, 3});
    const torch::Tensor norm = flat.norm(2, -1);
    pairs = torch::nonzero(norm > 0).reshape({-1});
    pair_vertex = torch::remainder(pairs, vertices);
    pair_deltas = flat.index_select(0, pairs).contiguous();                                      // [P, 3]
    magnitude = norm.index_select(0, pairs).unsqueeze(-1).contiguous();                          // [P, 1]
    direction = (pair_deltas / magnitude).contiguous();                                          // [P, 3]
    motion = torch::cat({pair_deltas, magnitude}, -1).div(sigma).contiguous();                  // [P, 4]
  }
  // features [B, A, F] (decoder features and input at each chart vertex) -> offsets [B, S, A, 3]:
  // the free part |S_i(x)| out(x) and the part along the motion, gain S_i(x) (undefined
  // without the frame).
  std::pair<torch::Tensor, torch::Tensor> forward(const torch::Tensor& features) {
    // Advanced indexing on the inner dimension rather than index_select / index_add: libtorch's
    // CPU index_add over a non-leading dimension runs one strided add per index (thousands of
    // pairs), while indexing and its accumulating backward run in one element loop.
    using torch::indexing::Slice;
    torch::Tensor hidden = from_features->forward(features).index({Slice(), pair_vertex}) +
                           from_motion->forward(motion).unsqueeze(0);  // [B, P, width]
    torch::Tensor d;  // the neutral's displacement at each pair's vertex [B, P, 3] (frame heads)
    if (frame) {
      d = features.narrow(2, displacement, 3).index({Slice(), pair_vertex});
      hidden = hidden + from_along->forward((d * direction).sum(-1, true));
      if (local) hidden = hidden + from_norm->forward(d.norm(2, -1, true));
    }
    hidden = torch::relu(hidden);
    if (!second.is_empty()) hidden = torch::relu(second->forward(hidden));
    const torch::Tensor out = output->forward(hidden);
    torch::Tensor free = out.narrow(2, 0, 3);
    if (local) {
      const torch::Tensor t = direction.unsqueeze(0).expand_as(d);
      free = out.narrow(2, 0, 1) * t + out.narrow(2, 1, 1) * d + out.narrow(2, 2, 1) * torch::cross(t, d, -1);
    }
    const int64_t B = features.size(0);
    auto scatter = [&](const torch::Tensor& values) {  // [B, P, 3] -> [B, S, A, 3] (pairs are distinct)
      return torch::zeros({B, shapes * vertices, 3}, values.options()).index_put_({Slice(), pairs}, values)
          .reshape({B, shapes, vertices, 3});
    };
    return {scatter(free * magnitude), frame ? scatter(out.narrow(2, 3, 1) * pair_deltas) : torch::Tensor()};
  }
  int64_t shapes, vertices;
  bool frame, local;
  int64_t displacement;
  // The moving pairs s A + x, their x, S_s(x), |S_s(x)|, S_s(x) / |S_s(x)|, the motion input.
  torch::Tensor pairs, pair_vertex, pair_deltas, magnitude, direction, motion;
  torch::nn::Linear from_features{nullptr}, from_motion{nullptr}, output{nullptr}, from_along{nullptr};
  torch::nn::Linear second{nullptr};  // the second hidden layer (head_depth 2)
  torch::nn::Linear from_norm{nullptr};  // |d(x)| into the hidden layer (local frame)
};
TORCH_MODULE(TemplateHead);

// Per-shape amplitude from the whole neutral: the neutral's displacement image averaged to
// 16 x 16, one tanh layer and a linear layer to one number a_i per shape, which scales the
// shape's motion along the template's path: S_i^j = (1 + a_i)(S_i + gain_i S_i) + free_i with
// amplitude_on_path (the heads' gain part; free: their other offsets and the 1x1 output), else
// S_i^j = (1 + a_i)(S_i + Delta S_i). How strongly a person performs a shape as a whole depends
// on their identity everywhere on the face (in the synthetic database, the factor g_i of a
// global identity projection), which the convolutions' local receptive fields cannot see.
// The output layer starts at zero (a = 0).
struct AmplitudeImpl : torch::nn::Module {
  static constexpr int kGrid = 16;
  static constexpr int kFeatures = 3 * kGrid * kGrid;
  // components > 0: a_i = gain_i tanh(w_i . z + c_i) on z, the whitened principal components
  // of the pooled image (the basis is set from the training people, see FitAmplitudeBasis):
  // in the synthetic database g_ij = 1 + 0.25 tanh(c_i . a_j) with a_j linear in the neutral.
  AmplitudeImpl(int width, int num_shapes, int components) : components(components) {
    if (components > 0) {
      output = register_module("output", torch::nn::Linear(components, num_shapes));
      gain = register_parameter("gain", torch::full({num_shapes}, 0.25f));
      mean = torch::zeros({kFeatures});
      basis = torch::zeros({components, kFeatures});
    } else {
      hidden = register_module("hidden", torch::nn::Linear(kFeatures, width));
      output = register_module("output", torch::nn::Linear(width, num_shapes));
    }
    torch::NoGradGuard no_grad;
    output->weight.zero_();
    output->bias.zero_();
  }
  // The pooled displacement image [B, kFeatures] of input [B, C, H, W] (first 3 channels).
  static torch::Tensor Pooled(const torch::Tensor& input) {
    return F::adaptive_avg_pool2d(input.narrow(1, 0, 3), F::AdaptiveAvgPool2dFuncOptions({kGrid, kGrid})).flatten(1);
  }
  // input [B, C, H, W] (the first 3 channels: the displacement image) -> a [B, N].
  torch::Tensor forward(const torch::Tensor& input) {
    const torch::Tensor pooled = Pooled(input);
    if (components > 0) return gain * torch::tanh(output->forward((pooled - mean).matmul(basis.t())));
    return output->forward(torch::tanh(hidden->forward(pooled)));
  }
  // The weight matrices the ridge term amplitude_decay penalizes.
  torch::Tensor RidgeTerm() const {
    torch::Tensor sum = output->weight.square().sum();
    return hidden.is_empty() ? sum : sum + hidden->weight.square().sum();
  }
  int components;
  torch::nn::Linear hidden{nullptr}, output{nullptr};
  torch::Tensor gain, mean, basis;  // gain: parameter; mean, basis: set from the data
};
TORCH_MODULE(Amplitude);

struct GeneratorOutput {
  torch::Tensor image;     // [B, 3N, H, W], channels in shape order (the 1x1 output layers)
  torch::Tensor features;  // [B, F, H, W], the branches' last features (large, then small)
  torch::Tensor input;     // [B, C, H, W], the generator's input
};

// Blendshape Generator: encoder + two branches, each with a 1x1 output convolution and, when
// head_width > 0, a template-conditioned head on the features sampled at the chart vertices.
// template_deltas: S_i on the chart vertices, [N, A, 3].
struct GeneratorImpl : torch::nn::Module {
  GeneratorImpl(int in, int c, int blocks, const std::vector<int>& large, int num_shapes, int head_width,
                int head_depth, bool head_frame, bool head_local_frame, int amplitude_width,
                int amplitude_components, const torch::Tensor& template_deltas)
      : channels(c) {
    encoder = register_module("encoder", Encoder(in, c, blocks));
    std::vector<uint8_t> is_large(num_shapes, 0);
    for (int i : large) is_large[i] = 1;
    std::vector<int64_t> order_large, order_small;
    for (int i = 0; i < num_shapes; ++i) (is_large[i] ? order_large : order_small).push_back(i);
    large_branch = register_module("large", Decoder(c, 3 * static_cast<int>(order_large.size())));
    small_branch = register_module("small", Decoder(c, 3 * static_cast<int>(order_small.size())));
    // Shape and channel permutations from [large..., small...] back to shape order.
    std::vector<int64_t> position(num_shapes);
    for (size_t k = 0; k < order_large.size(); ++k) position[order_large[k]] = static_cast<int64_t>(k);
    for (size_t k = 0; k < order_small.size(); ++k) position[order_small[k]] = static_cast<int64_t>(order_large.size() + k);
    std::vector<int64_t> channel_order;
    for (int i = 0; i < num_shapes; ++i) for (int d = 0; d < 3; ++d) channel_order.push_back(3 * position[i] + d);
    permutation = torch::tensor(channel_order, torch::kLong);
    shape_permutation = torch::tensor(position, torch::kLong);
    has_large = !order_large.empty();
    has_small = !order_small.empty();
    branch_shapes[0] = order_large;
    branch_shapes[1] = order_small;
    if (head_width > 0) {
      const double sigma = template_deltas.square().sum(-1).mean().sqrt().item<double>() + 1e-6;
      auto branch = [&](const std::vector<int64_t>& order, const char* name, TemplateHead* head) {
        if (order.empty()) return;
        const torch::Tensor deltas = template_deltas.index_select(0, torch::tensor(order, torch::kLong));
        // The head's features: the branch's c decoder features, then the input (displacement first).
        *head = register_module(name, TemplateHead(c + in, head_width, head_depth, deltas, sigma, head_frame, c, head_local_frame));
      };
      branch(order_large, "large_head", &heads[0]);
      branch(order_small, "small_head", &heads[1]);
    }
    if (amplitude_width > 0 || amplitude_components > 0) {
      amplitude = register_module("amplitude", Amplitude(amplitude_width, num_shapes, amplitude_components));
    }
  }
  GeneratorOutput forward(const torch::Tensor& x) {
    const torch::Tensor code = encoder->forward(x);
    std::vector<torch::Tensor> images, features;
    for (Decoder* d : {has_large ? &large_branch : nullptr, has_small ? &small_branch : nullptr}) {
      if (!d) continue;
      features.push_back((*d)->Features(code));
      images.push_back((*d)->output->forward(features.back()));
    }
    return {torch::cat(images, 1).index_select(1, permutation), torch::cat(features, 1), x};
  }
  bool HasHeads() const { return !heads[0].is_empty() || !heads[1].is_empty(); }
  // The heads' offsets [B, N, A, 3] (shape order) from the features [B, F, A] and the input
  // [B, C, A] sampled at the chart vertices: free and along the motion (undefined without the
  // frame).
  std::pair<torch::Tensor, torch::Tensor> HeadOffsets(const torch::Tensor& sampled, const torch::Tensor& sampled_input) {
    std::vector<torch::Tensor> free, along;
    int64_t first = 0;
    for (TemplateHead& head : heads) {
      if (head.is_empty()) continue;
      auto [f, a] = head->forward(torch::cat({sampled.narrow(1, first, channels), sampled_input}, 1).transpose(1, 2));
      free.push_back(f);
      if (a.defined()) along.push_back(a);
      first += channels;
    }
    auto order = [&](const std::vector<torch::Tensor>& parts) {
      return parts.size() == free.size() ? torch::cat(parts, 1).index_select(1, shape_permutation) : torch::Tensor();
    };
    return {order(free), order(along)};
  }
  int channels;
  Encoder encoder{nullptr};
  Decoder large_branch{nullptr}, small_branch{nullptr};
  TemplateHead heads[2] = {TemplateHead{nullptr}, TemplateHead{nullptr}};  // large, small
  Amplitude amplitude{nullptr};  // per-shape amplitude (optional)
  std::vector<int64_t> branch_shapes[2];  // the shapes of the large and the small branch
  torch::Tensor permutation, shape_permutation;
  bool has_large = false, has_small = false;
};
TORCH_MODULE(Generator);

// Blending Weight Predictor: expression encoder to N weights in [0, 1]. The output layer
// starts at zero so the first prediction is the nominal weights (clamped to [0.018, 0.982]).
struct WeightPredictorImpl : torch::nn::Module {
  WeightPredictorImpl(int in, int c, int num_shapes) {
    layers = register_module("layers", torch::nn::Sequential());
    layers->push_back(torch::nn::AvgPool2d(torch::nn::AvgPool2dOptions(2)));
    layers->push_back(Conv(in, c, 4, 2));
    layers->push_back(torch::nn::ReLU());
    layers->push_back(Conv(c, 2 * c, 4, 2));
    layers->push_back(torch::nn::ReLU());
    layers->push_back(Conv(2 * c, 2 * c, 4, 2));
    layers->push_back(torch::nn::ReLU());
    layers->push_back(torch::nn::AdaptiveAvgPool2d(torch::nn::AdaptiveAvgPool2dOptions({4, 4})));
    layers->push_back(torch::nn::Flatten());
    output = register_module("output", torch::nn::Linear(2 * c * 16, num_shapes));
    torch::NoGradGuard no_grad;
    output->weight.zero_();
    output->bias.zero_();
  }
  torch::Tensor forward(const torch::Tensor& x, const torch::Tensor& nominal) {
    return torch::sigmoid(torch::logit(nominal.clamp(0.018f, 0.982f)) + output->forward(layers->forward(x)));
  }
  torch::nn::Sequential layers{nullptr};
  torch::nn::Linear output{nullptr};
};
TORCH_MODULE(WeightPredictor);

// ---------------------------------------------------------------------------------------------
// Inference form of the generators (PredictOffsets): the arithmetic of GeneratorImpl::forward
// for one image on one core, prepared once from the parameters.
// - Every convolution runs in oneDNN on tensors kept in its blocked layout, with the weights
//   reordered once (libtorch's default picks im2col + BLAS for batch-1 3x3 and 1x1
//   convolutions, several times slower here). Instance normalization and nearest upsampling
//   run on plain buffers between the convolutions. Without oneDNN (a libtorch built without
//   it, or with it switched off) the same runs on plain tensors.
// - The decoders' 1x1 output convolutions, the channel permutation and the bilinear sampling at
//   the chart vertices are all linear, so they fold into one matrix applied to the sampled
//   last decoder features: offsets = M [S f; S 1] (S: the sampling stencil, 1: a channel of
//   ones carrying the biases). Nothing at H x W with 3N channels is ever formed.
// - The heads run on the same samples of the features (FastHeads: their motion term
//   precomputed per moving pair, plain loops over the pairs).
// Results equal the modules' forward up to float rounding (the order of the sums differs).

bool UseOneDnn() { return at::hasMKLDNN() && at::globalContext().userEnabledMkldnn(); }

// To the convolutions' layout (oneDNN's when `onednn`) and back.
torch::Tensor ToNet(const torch::Tensor& t, bool onednn) { return onednn && !t.is_mkldnn() ? t.to_mkldnn() : t; }
torch::Tensor ToDense(const torch::Tensor& t) { return t.is_mkldnn() ? t.to_dense() : t; }

struct FastConv {
  torch::Tensor weight, bias;
  int64_t padding = 0, stride = 1;

  FastConv() = default;
  FastConv(const torch::Tensor& w, const torch::Tensor& b, int64_t pad, int64_t str, bool onednn)
      : bias(b.detach().clone()), padding(pad), stride(str) {
    const torch::Tensor dense = w.detach().contiguous().clone();
    weight = onednn ? at::mkldnn_reorder_conv2d_weight(dense.to_mkldnn(), {padding, padding}, {stride, stride}, {1, 1}, 1)
                    : dense;
  }
  FastConv(const torch::nn::Conv2d& conv, bool onednn)
      : FastConv(conv->weight, conv->bias, (*c10::get<torch::ExpandingArray<2>>(conv->options.padding()))[0],
                 (*conv->options.stride())[0], onednn) {}
  // x in the convolutions' layout; the result too.
  torch::Tensor operator()(const torch::Tensor& x) const {
    if (weight.is_mkldnn()) return at::mkldnn_convolution(x, weight, bias, {padding, padding}, {stride, stride}, {1, 1}, 1);
    return torch::conv2d(x, weight, bias, stride, padding);
  }
};

// In place on a dense contiguous [1, C, H, W] tensor: per-channel normalization to zero mean
// and unit (biased) variance, eps 1e-5, as F::instance_norm without affine parameters.
void InstanceNormalize(torch::Tensor& t) {
  const int64_t C = t.size(1), P = t.size(2) * t.size(3);
  float* data = t.data_ptr<float>();
  for (int64_t c = 0; c < C; ++c) {
    float* x = data + c * P;
    double sum = 0, sq = 0;
    for (int64_t p = 0; p < P; ++p) sum += x[p];
    const double mean = sum / static_cast<double>(P);
    for (int64_t p = 0; p < P; ++p) sq += (x[p] - mean) * (x[p] - mean);
    const double var = sq / static_cast<double>(P);
    const float m = static_cast<float>(mean), inv = static_cast<float>(1.0 / std::sqrt(var + 1e-5));
    for (int64_t p = 0; p < P; ++p) x[p] = (x[p] - m) * inv;
  }
}

void ReluInPlace(torch::Tensor& t) {
  float* x = t.data_ptr<float>();
  for (int64_t i = 0, n = t.numel(); i < n; ++i) x[i] = x[i] > 0.f ? x[i] : 0.f;
}

// Nearest upsampling by 2 of a dense contiguous [1, C, H, W] tensor.
torch::Tensor Upsample2(const torch::Tensor& t) {
  const int64_t C = t.size(1), H = t.size(2), W = t.size(3);
  torch::Tensor out = torch::empty({1, C, 2 * H, 2 * W}, t.options());
  const float* in = t.data_ptr<float>();
  float* o = out.data_ptr<float>();
  for (int64_t c = 0; c < C; ++c) {
    for (int64_t y = 0; y < H; ++y) {
      const float* row = in + (c * H + y) * W;
      float* a = o + (c * 2 * H + 2 * y) * 2 * W;
      for (int64_t x = 0; x < W; ++x) a[2 * x] = a[2 * x + 1] = row[x];
      std::copy(a, a + 2 * W, a + 2 * W);
    }
  }
  return out;
}

struct FastResidual {
  FastConv first, second;
  bool normalize = false, onednn = false;
  FastResidual(const ResidualBlockImpl& b, bool use_onednn)
      : first(b.first, use_onednn), second(b.second, use_onednn), normalize(b.normalize), onednn(use_onednn) {}
  // x in the convolutions' layout; the result too.
  torch::Tensor operator()(const torch::Tensor& x) const {
    if (!normalize) return x + second(torch::relu(first(x)));
    torch::Tensor y = ToDense(first(x)).contiguous();
    InstanceNormalize(y);
    ReluInPlace(y);
    y = ToDense(second(ToNet(y, onednn))).contiguous();
    InstanceNormalize(y);
    return ToNet(ToDense(x) + y, onednn);
  }
};

struct FastGenerator {
  std::vector<FastConv> convs;         // the encoder's three convolutions (each + ReLU)
  std::vector<FastResidual> blocks;    // the encoder's residual blocks
  struct Branch {
    std::vector<FastResidual> block;   // one instance-normalized residual block
    FastConv up1, up2;
  };
  std::vector<Branch> branches;        // large then small, those with outputs
  std::vector<const DecoderImpl*> decoders;  // their modules (for the output layers)
  bool onednn = false;

  FastGenerator(const GeneratorImpl& g, bool use_onednn) : onednn(use_onednn) {
    for (const auto& child : g.encoder->layers->children()) {
      if (auto conv = std::dynamic_pointer_cast<torch::nn::Conv2dImpl>(child)) {
        convs.emplace_back(torch::nn::Conv2d(conv), onednn);
      } else if (auto block = std::dynamic_pointer_cast<ResidualBlockImpl>(child)) {
        blocks.emplace_back(*block, onednn);
      }
    }
    auto add = [&](const Decoder& d) {
      Branch b;
      b.block.emplace_back(*d->block, onednn);
      b.up1 = FastConv(d->up1, onednn);
      b.up2 = FastConv(d->up2, onednn);
      branches.push_back(std::move(b));
      decoders.push_back(d.get());
    };
    if (g.has_large) add(g.large_branch);
    if (g.has_small) add(g.small_branch);
  }
  // The last decoder features (before the output convolutions) of every branch, concatenated:
  // dense [1, F, H, W] with F = branches x channels.
  torch::Tensor Features(const torch::Tensor& input) const {
    torch::Tensor y = ToNet(input, onednn);
    for (const FastConv& c : convs) y = torch::relu(c(y));
    for (const FastResidual& b : blocks) y = b(y);
    std::vector<torch::Tensor> features;
    for (const Branch& branch : branches) {
      torch::Tensor z = branch.block[0](y);
      z = torch::relu(branch.up1(ToNet(Upsample2(ToDense(z).contiguous()), onednn)));
      z = torch::relu(branch.up2(ToNet(Upsample2(ToDense(z).contiguous()), onednn)));
      features.push_back(ToDense(z));
    }
    return features.size() == 1 ? features[0].contiguous() : torch::cat(features, 1);
  }
};

using MatrixXdRow = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// The output layers of a generator as one matrix on [features; 1]: rows are the image channels
// in shape order (3 i + d), the last column the biases. permutation: GeneratorImpl's.
MatrixXdRow OutputMatrix(const FastGenerator& g, const torch::Tensor& permutation) {
  std::vector<MatrixXdRow> blocks;  // per branch: [outputs x (features + 1)]
  int64_t features = 0, outputs = 0;
  for (const DecoderImpl* d : g.decoders) {
    const torch::Tensor w = d->output->weight.detach().to(torch::kFloat64).contiguous();
    const torch::Tensor b = d->output->bias.detach().to(torch::kFloat64).contiguous();
    const int64_t out = w.size(0), in = w.size(1);
    MatrixXdRow m(out, in + 1);
    for (int64_t o = 0; o < out; ++o) {
      for (int64_t i = 0; i < in; ++i) m(o, i) = w.data_ptr<double>()[o * in + i];
      m(o, in) = b.data_ptr<double>()[o];
    }
    blocks.push_back(m);
    features += in;
    outputs += out;
  }
  // Concatenated channels (branch order) as rows of [features + 1].
  MatrixXdRow cat = MatrixXdRow::Zero(outputs, features + 1);
  int64_t row = 0, col = 0;
  for (const MatrixXdRow& m : blocks) {
    const int64_t in = m.cols() - 1;
    cat.block(row, col, m.rows(), in) = m.leftCols(in);
    cat.block(row, features, m.rows(), 1) = m.rightCols(1);
    row += m.rows();
    col += in;
  }
  MatrixXdRow out(outputs, features + 1);
  const int64_t* perm = permutation.data_ptr<int64_t>();
  for (int64_t r = 0; r < outputs; ++r) out.row(r) = cat.row(perm[r]);
  return out;
}

// The inference form of a generator's heads (TemplateHeadImpl::forward on one image): the
// hidden layer's motion term is fixed for given parameters and precomputed per moving pair;
// the feature term is computed once per chart vertex; the rest runs in plain loops over the
// pairs, adding into the offsets.
struct FastHeads {
  using RowMajor = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  struct Head {
    Eigen::MatrixXf from_features;  // [width, c + C]
    Eigen::VectorXf bias;           // [width]
    Eigen::MatrixXf motion;         // [width, P]: the motion term of each pair
    Eigen::MatrixXf output;         // [3 or 4, width]
    Eigen::MatrixXf second;         // [width, width]: the second hidden layer (empty: none)
    Eigen::VectorXf second_bias;
    Eigen::VectorXf output_bias;
    Eigen::VectorXf along;          // [width]: weights of d . direction (frame heads)
    Eigen::VectorXf norm;           // [width]: weights of |d| (local frame heads; empty: none)
    Eigen::MatrixXf deltas, direction;   // [3, P]: S_i(x) and its direction (frame heads)
    std::vector<int64_t> vertex, shape;  // per pair: chart vertex, shape (shape order)
    std::vector<float> magnitude;        // per pair: |S_i(x)|
    int64_t first_feature = 0;           // the branch's first row among the sampled features
    bool frame = false;
    int64_t displacement = 0;            // row of the displacement among [features; input]
  };
  std::vector<Head> heads;
  int64_t channels = 0;

  explicit FastHeads(const GeneratorImpl& g) : channels(g.channels) {
    auto matrix = [](const torch::Tensor& t) {
      const torch::Tensor c = t.detach().contiguous();
      return Eigen::MatrixXf(Eigen::Map<const RowMajor>(c.data_ptr<float>(), c.size(0), c.size(1)));
    };
    int64_t first = 0;
    for (int b = 0; b < 2; ++b) {
      if (g.heads[b].is_empty()) continue;
      const TemplateHeadImpl& t = *g.heads[b];
      Head h;
      h.from_features = matrix(t.from_features->weight);
      h.bias = matrix(t.from_features->bias.unsqueeze(1));
      h.motion = matrix(torch::matmul(t.motion, t.from_motion->weight.detach().t()).t());
      h.output = matrix(t.output->weight);
      h.output_bias = matrix(t.output->bias.unsqueeze(1));
      if (!t.second.is_empty()) {
        h.second = matrix(t.second->weight);
        h.second_bias = matrix(t.second->bias.unsqueeze(1));
      }
      h.frame = t.frame;
      h.displacement = t.displacement;
      if (t.frame) {
        h.along = matrix(t.from_along->weight);
        if (t.local) h.norm = matrix(t.from_norm->weight);
        h.deltas = matrix(t.pair_deltas.t());
        h.direction = matrix(t.direction.t());
      }
      const int64_t P = t.pairs.size(0);
      const int64_t* pairs = t.pairs.data_ptr<int64_t>();
      for (int64_t p = 0; p < P; ++p) {
        h.vertex.push_back(pairs[p] % t.vertices);
        h.shape.push_back(g.branch_shapes[b][pairs[p] / t.vertices]);
        h.magnitude.push_back(t.magnitude.data_ptr<float>()[p]);
      }
      h.first_feature = first;
      first += g.channels;
      heads.push_back(std::move(h));
    }
  }
  // features: the generator's sampled features [F, A]; input: its sampled input [C, A] (both
  // row-major); adds the heads' free offsets to out and those along the motion to along (both
  // [N, A, 3]; along may be out).
  void Add(const float* features, const float* input, int64_t input_channels, int64_t A, float* out,
           float* along_out) const {
    for (const Head& h : heads) {
      RowMajor x(channels + input_channels, A);
      x.topRows(channels) = Eigen::Map<const RowMajor>(features + h.first_feature * A, channels, A);
      x.bottomRows(input_channels) = Eigen::Map<const RowMajor>(input, input_channels, A);
      const Eigen::MatrixXf per_vertex = (h.from_features * x).colwise() + h.bias;  // [width, A]
      Eigen::VectorXf hidden(per_vertex.rows()), deeper(h.second.rows()), o(h.output.rows());
      for (size_t p = 0; p < h.vertex.size(); ++p) {
        const int64_t v = h.vertex[p];
        hidden = per_vertex.col(v) + h.motion.col(p);
        const Eigen::Vector3f d = h.frame ? Eigen::Vector3f(x(h.displacement, v), x(h.displacement + 1, v),
                                                            x(h.displacement + 2, v))
                                          : Eigen::Vector3f::Zero();
        if (h.frame) {
          hidden += d.dot(h.direction.col(p)) * h.along;
          if (h.norm.size() > 0) hidden += d.norm() * h.norm;
        }
        hidden = hidden.cwiseMax(0.f);
        if (h.second.size() > 0) {
          deeper.noalias() = h.second * hidden;
          hidden = (deeper + h.second_bias).cwiseMax(0.f);
        }
        o.noalias() = h.output * hidden;
        o += h.output_bias;
        float* y = out + (h.shape[p] * A + v) * 3;
        if (h.norm.size() > 0) {
          const Eigen::Vector3f t = h.direction.col(p);
          const Eigen::Vector3f free = o[0] * t + o[1] * d + o[2] * t.cross(d);
          for (int c = 0; c < 3; ++c) y[c] += free[c] * h.magnitude[p];
        } else {
          for (int c = 0; c < 3; ++c) y[c] += o[c] * h.magnitude[p];
        }
        if (h.frame) {
          float* z = along_out + (h.shape[p] * A + v) * 3;
          for (int c = 0; c < 3; ++c) z[c] += o[3] * h.deltas(c, p);
        }
      }
    }
  }
};

}  // namespace

bool BlendshapeNetOptions::Check(std::string* why) const {
  if (channels < 2 || channels > 128) { *why = "channels must be in [2, 128]"; return false; }
  if (residual_blocks < 0 || residual_blocks > 8) { *why = "residual_blocks must be in [0, 8]"; return false; }
  if (head_width < 0 || head_width > 256) { *why = "head_width must be in [0, 256]"; return false; }
  if (head_depth < 1 || head_depth > 2) { *why = "head_depth must be 1 or 2"; return false; }
  if (amplitude_width < 0 || amplitude_width > 256) { *why = "amplitude_width must be in [0, 256]"; return false; }
  if (amplitude_components < 0 || amplitude_components > 256) { *why = "amplitude_components must be in [0, 256]"; return false; }
  if (!(learning_rate > 0.f && learning_rate < 1.f)) { *why = "learning_rate must be in (0, 1)"; return false; }
  if (!(reg_weight >= 0.f)) { *why = "reg_weight must be >= 0"; return false; }
  if (!(tuning_reg_weight >= 0.f)) { *why = "tuning_reg_weight must be >= 0"; return false; }
  if (!(amplitude_decay >= 0.f)) { *why = "amplitude_decay must be >= 0"; return false; }
  if (!(weight_decay >= 0.f)) { *why = "weight_decay must be >= 0"; return false; }
  return true;
}

void SetTensorThreads(int threads) {
  if (threads > 0) torch::set_num_threads(threads);
}

struct BlendshapeGenerator::Impl {
  BlendshapeNetOptions options;
  std::shared_ptr<const BlendshapeNetGeometry> geometry;
  Generator generator{nullptr};        // Estimation Stage
  Generator tuning{nullptr};           // Tuning Stage generator (skip connection on its output)
  torch::nn::Conv2d offsets_in{nullptr};  // Estimation decoder features -> c channels (tuning input)
  WeightPredictor predictor{nullptr};
  std::vector<torch::Tensor> parameters;
  std::vector<uint8_t> decays;         // per parameter: shrunk by weight_decay (weight matrices)
  int64_t estimation_end = 0;          // parameters [0, estimation_end) are the generator's
  int64_t num_parameters = 0;
  std::vector<float> gradient, adam_m, adam_v;
  int64_t steps[2] = {0, 0};
  torch::Tensor template_deltas, reg_weights, sample_pixels, sample_weights, static_channels;

  int64_t N() const { return geometry->num_shapes; }
  int64_t A() const { return geometry->num_chart_vertices; }
  int64_t H() const { return geometry->image_size; }

  torch::Tensor WithStatic(const torch::Tensor& images) const {
    if (geometry->num_static_channels == 0) return images;
    return torch::cat({images, static_channels.expand({images.size(0), -1, -1, -1})}, 1);
  }
  // [B, C, H, W] -> [B, C, A]: bilinear samples at the chart vertices.
  torch::Tensor SampleChannels(const torch::Tensor& image) const {
    const int64_t B = image.size(0), C = image.size(1);
    using torch::indexing::Slice;
    torch::Tensor flat = image.reshape({B, C, H() * H()}).index({Slice(), Slice(), sample_pixels});
    return (flat.reshape({B, C, A(), 4}) * sample_weights).sum(-1);
  }
  // A generator's offsets Delta S_i at the chart vertices, [B, N, A, 3]: its output image
  // sampled plus its heads' free offsets, and its heads' offsets along the template motion
  // (undefined without frame heads).
  struct OffsetParts {
    torch::Tensor free, along;
  };
  OffsetParts Offsets(Generator& g, const GeneratorOutput& out) {
    const torch::Tensor linear = SampleChannels(out.image).reshape({out.image.size(0), N(), 3, A()}).permute({0, 1, 3, 2});
    if (!g->HasHeads()) return {linear, torch::Tensor()};
    auto [free, along] = g->HeadOffsets(SampleChannels(out.features), SampleChannels(out.input));
    return {linear + free, along};
  }
  // The Estimation generator's per-shape amplitude a [B, N] (zeros without one).
  torch::Tensor AmplitudeOf(const torch::Tensor& input) {
    if (generator->amplitude.is_empty()) return torch::zeros({input.size(0), N()}, input.options());
    return generator->amplitude->forward(input);
  }
  // The offsets with the amplitude a [B, N] applied to what it scales: all of them, or with
  // amplitude_on_path only those along the template motion. Amplified adds a_i S_i: the
  // shapes are then (1 + a_i)(S_i + offsets_i), or (1 + a_i)(S_i + along_i) + free_i.
  torch::Tensor Scaled(const OffsetParts& parts, const torch::Tensor& amplitude) const {
    const torch::Tensor a = amplitude.unsqueeze(-1).unsqueeze(-1);
    const torch::Tensor all = parts.along.defined() ? parts.free + parts.along : parts.free;
    if (!options.amplitude_on_path) return all * (1.f + a);
    return parts.along.defined() ? all + a * parts.along : all;
  }
  torch::Tensor Amplified(const OffsetParts& parts, const torch::Tensor& amplitude) const {
    return Scaled(parts, amplitude) + amplitude.unsqueeze(-1).unsqueeze(-1) * template_deltas;
  }
  // The Tuning generator sees the neutral and the initial blendshapes through the Estimation
  // decoders' last features (the offsets are computed from them), compressed to c channels.
  GeneratorOutput TuningForward(const torch::Tensor& input, const GeneratorOutput& estimation) {
    return tuning->forward(torch::cat({input, torch::relu(offsets_in->forward(estimation.features))}, 1));
  }

  // The inference form (see FastGenerator), built from the parameters on first use and dropped
  // whenever they change (a caller still running on the old one keeps it alive).
  struct Inference {
    std::unique_ptr<FastGenerator> generator, tuning;
    FastConv offsets_in;      // offsets_in on the Estimation features
    int64_t generator_features = 0, tuning_features = 0;
    // Output layers on the sampled [generator features; 1] (Estimation only) and on
    // [generator features; 1; tuning features; 1] (tuned), as 1x1 convolution weights
    // [3N, rows, 1, 1] applied to the samples laid out as a [1, rows, 1, A] image.
    FastConv output, output_tuned;
    std::unique_ptr<FastHeads> generator_heads, tuning_heads;
    bool onednn = false;      // convolutions in oneDNN (else plain libtorch)
  };
  std::shared_ptr<const Inference> inference;
  std::mutex inference_mutex;

  std::shared_ptr<const Inference> InferenceForm() {
    std::lock_guard<std::mutex> lock(inference_mutex);
    if (inference) return inference;
    torch::NoGradGuard no_grad;
    auto f = std::make_unique<Inference>();
    f->onednn = UseOneDnn();
    f->generator = std::make_unique<FastGenerator>(*generator, f->onednn);
    f->tuning = std::make_unique<FastGenerator>(*tuning, f->onednn);
    const MatrixXdRow mg = OutputMatrix(*f->generator, generator->permutation);
    const MatrixXdRow mt = OutputMatrix(*f->tuning, tuning->permutation);
    const int64_t fg = mg.cols() - 1, ft = mt.cols() - 1, outputs = mg.rows();
    f->generator_features = fg;
    f->tuning_features = ft;
    f->offsets_in = FastConv(offsets_in, f->onednn);
    MatrixXdRow both(outputs, fg + 1 + ft + 1);
    both << mg, mt;
    auto as_conv = [&](const MatrixXdRow& m) {
      const Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> w = m.cast<float>();
      return FastConv(torch::from_blob(const_cast<float*>(w.data()), {w.rows(), w.cols(), 1, 1}, torch::kFloat32),
                      torch::zeros({w.rows()}, torch::kFloat32), 0, 1, f->onednn);
    };
    f->output = as_conv(mg);
    f->output_tuned = as_conv(both);
    f->generator_heads = std::make_unique<FastHeads>(*generator);
    f->tuning_heads = std::make_unique<FastHeads>(*tuning);
    inference = std::move(f);
    return inference;
  }
  // generator_changed: the Estimation networks' parameters (or the amplitude basis) may have
  // changed, so their cached per-person outputs go too.
  void DropInference(bool generator_changed = true) {
    std::lock_guard<std::mutex> lock(inference_mutex);
    inference.reset();
    if (generator_changed) estimation_cache.clear();
  }

  // What the Tuning Stage reads from the fixed Estimation networks for one person: their
  // decoder features [1, F, H, W], amplitude [1, N] and initial offsets [1, N, A, 3]. They do
  // not change while the Tuning Stage trains, so each person's are computed once (alone, so
  // they do not depend on the batch the person comes in) instead of at every step.
  struct EstimationEntry {
    std::vector<float> neutral_image;  // the key's content, checked on every lookup
    torch::Tensor features, amplitude, initial;
  };
  std::unordered_map<const BlendshapePerson*, EstimationEntry> estimation_cache;
  const EstimationEntry& Estimation(const BlendshapePerson& person) {
    auto it = estimation_cache.find(&person);
    if (it != estimation_cache.end() && it->second.neutral_image == person.neutral_image) return it->second;
    torch::NoGradGuard no_grad;
    EstimationEntry e;
    e.neutral_image = person.neutral_image;
    const torch::Tensor input =
        WithStatic(torch::from_blob(e.neutral_image.data(), {1, 3, H(), H()}, torch::kFloat32));
    const GeneratorOutput out = generator->forward(input);
    e.amplitude = AmplitudeOf(input);
    e.initial = Amplified(Offsets(generator, out), e.amplitude);
    e.features = out.features;
    return estimation_cache[&person] = std::move(e);
  }
};

BlendshapeGenerator::BlendshapeGenerator(const BlendshapeNetOptions& options,
                                         std::shared_ptr<const BlendshapeNetGeometry> geometry)
    : impl_(std::make_unique<Impl>()) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError("blendshape generator: " + why);
  const BlendshapeNetGeometry& g = *geometry;
  if (g.image_size % 4 != 0 || g.num_shapes <= 0 || g.num_chart_vertices <= 0 ||
      g.template_deltas.size() != static_cast<size_t>(g.num_shapes) * g.num_chart_vertices * 3 ||
      g.reg_weights.size() != static_cast<size_t>(g.num_shapes) * g.num_chart_vertices ||
      g.sample_pixels.size() != static_cast<size_t>(g.num_chart_vertices) * 4 ||
      g.sample_weights.size() != g.sample_pixels.size() ||
      g.static_channels.size() != static_cast<size_t>(g.num_static_channels) * g.image_size * g.image_size) {
    throw InvalidInputError("blendshape generator: inconsistent geometry sizes");
  }
  Impl& m = *impl_;
  m.options = options;
  m.geometry = geometry;
  torch::manual_seed(static_cast<uint64_t>(options.seed));
  const int c = options.channels, in = 3 + g.num_static_channels;
  auto f32 = torch::TensorOptions().dtype(torch::kFloat32);
  m.template_deltas = torch::from_blob(const_cast<float*>(g.template_deltas.data()),
                                       {g.num_shapes, g.num_chart_vertices, 3}, f32).clone();
  m.generator = Generator(in, c, options.residual_blocks, g.large_motion_shapes, g.num_shapes, options.head_width,
                          options.head_depth, options.head_frame, options.head_local_frame, options.amplitude_width,
                          options.amplitude_components,
                          m.template_deltas);
  m.tuning = Generator(in + c, c, options.residual_blocks, g.large_motion_shapes, g.num_shapes, options.head_width,
                       options.head_depth, options.head_frame, options.head_local_frame, 0, 0, m.template_deltas);
  const int branches = (m.generator->has_large ? 1 : 0) + (m.generator->has_small ? 1 : 0);
  m.offsets_in = Conv(branches * c, c, 1);
  m.predictor = WeightPredictor(in, c, g.num_shapes);
  for (auto& p : m.generator->parameters()) m.parameters.push_back(p);
  m.estimation_end = static_cast<int64_t>(m.parameters.size());
  for (auto& p : m.tuning->parameters()) m.parameters.push_back(p);
  for (auto& p : m.offsets_in->parameters()) m.parameters.push_back(p);
  for (auto& p : m.predictor->parameters()) m.parameters.push_back(p);
  for (auto& p : m.parameters) m.num_parameters += p.numel();
  std::vector<const void*> amplitude_parameters;
  if (!m.generator->amplitude.is_empty()) {
    for (auto& p : m.generator->amplitude->parameters()) amplitude_parameters.push_back(p.unsafeGetTensorImpl());
  }
  for (auto& p : m.parameters) {
    const bool amplitude = std::find(amplitude_parameters.begin(), amplitude_parameters.end(),
                                     p.unsafeGetTensorImpl()) != amplitude_parameters.end();
    m.decays.push_back(p.dim() >= 2 && !amplitude ? 1 : 0);
  }
  m.gradient.assign(m.num_parameters, 0.f);
  m.adam_m.assign(m.num_parameters, 0.f);
  m.adam_v.assign(m.num_parameters, 0.f);
  m.reg_weights = torch::from_blob(const_cast<float*>(g.reg_weights.data()),
                                   {g.num_shapes, g.num_chart_vertices}, f32).clone();
  std::vector<int64_t> pixels(g.sample_pixels.begin(), g.sample_pixels.end());
  m.sample_pixels = torch::tensor(pixels, torch::kLong);
  m.sample_weights = torch::from_blob(const_cast<float*>(g.sample_weights.data()),
                                      {g.num_chart_vertices, 4}, f32).clone();
  m.static_channels = torch::from_blob(const_cast<float*>(g.static_channels.data()),
                                       {1, g.num_static_channels, g.image_size, g.image_size}, f32).clone();
}

BlendshapeGenerator::~BlendshapeGenerator() = default;

int64_t BlendshapeGenerator::NumParameters() const { return impl_->num_parameters; }
float* BlendshapeGenerator::GradientBuffer() { return impl_->gradient.data(); }

double BlendshapeGenerator::Backward(const std::vector<const BlendshapePerson*>& batch,
                                     TrainingStage stage, float loss_scale,
                                     double* reconstruction) {
  Impl& m = *impl_;
  std::fill(m.gradient.begin(), m.gradient.end(), 0.f);
  if (reconstruction) *reconstruction = 0;
  if (batch.empty()) return 0;
  for (auto& p : m.parameters) {
    if (p.grad().defined()) p.mutable_grad() = torch::Tensor();
  }
  const int64_t B = static_cast<int64_t>(batch.size()), N = m.N(), A = m.A(), H = m.H();
  const int64_t K = batch[0]->num_expressions;
  std::vector<float> neutral_images, neutrals, expressions, nominal, expression_images;
  for (const BlendshapePerson* p : batch) {
    if (p->num_expressions != K) throw InvalidInputError("blendshape training: people differ in expression count");
    neutral_images.insert(neutral_images.end(), p->neutral_image.begin(), p->neutral_image.end());
    neutrals.insert(neutrals.end(), p->neutral.begin(), p->neutral.end());
    expressions.insert(expressions.end(), p->expressions.begin(), p->expressions.end());
    nominal.insert(nominal.end(), p->nominal_weights.begin(), p->nominal_weights.end());
    if (stage == TrainingStage::kTuning) {
      expression_images.insert(expression_images.end(), p->expression_images.begin(), p->expression_images.end());
    }
  }
  auto f32 = torch::TensorOptions().dtype(torch::kFloat32);
  const torch::Tensor input = m.WithStatic(torch::from_blob(neutral_images.data(), {B, 3, H, H}, f32));
  const torch::Tensor neutral = torch::from_blob(neutrals.data(), {B, 1, A * 3}, f32);
  const torch::Tensor target = torch::from_blob(expressions.data(), {B, K, A * 3}, f32);
  const torch::Tensor alpha = torch::from_blob(nominal.data(), {B, K, N}, f32);

  torch::Tensor offsets, weights, regularization;
  if (stage == TrainingStage::kEstimation) {
    offsets = m.Amplified(m.Offsets(m.generator, m.generator->forward(input)), m.AmplitudeOf(input));  // Delta S_i, [B,N,A,3]
    weights = alpha;
    // L_reg (eq. 4): sum_i g_i m_i(x) |Delta S_i(x)|_1, as a mean over shapes and vertices.
    regularization = (m.reg_weights * offsets.abs().sum(-1)).mean({1, 2});
  } else {
    GeneratorOutput estimation;
    torch::Tensor initial, amplitude;
    {
      std::vector<torch::Tensor> features, amplitudes, initials;
      for (const BlendshapePerson* p : batch) {
        const Impl::EstimationEntry& e = m.Estimation(*p);
        features.push_back(e.features);
        amplitudes.push_back(e.amplitude);
        initials.push_back(e.initial);
      }
      estimation.features = torch::cat(features, 0);
      amplitude = torch::cat(amplitudes, 0);
      initial = torch::cat(initials, 0);
    }
    // The Tuning generator's output joins the Estimation offsets before the amplitude:
    // (1 + a)(S + E + T) - S = Delta S_i + (1 + a) T (on the path only: T's along part scaled).
    const torch::Tensor residual = m.Scaled(m.Offsets(m.tuning, m.TuningForward(input, estimation)), amplitude);
    offsets = initial + residual;                                          // Delta S_i_FT (skip)
    const torch::Tensor images =
        m.WithStatic(torch::from_blob(expression_images.data(), {B * K, 3, H, H}, f32));
    weights = m.predictor->forward(images, alpha.reshape({B * K, N})).reshape({B, K, N});
    // L_reg_FT (eq. 8): |Delta S_i_FT - Delta S_i|_1, mean over shapes and vertices.
    regularization = residual.abs().sum(-1).mean({1, 2});
  }
  const torch::Tensor shapes = (m.template_deltas + offsets).reshape({B, N, A * 3});  // eq. 3
  const torch::Tensor rebuilt = neutral + torch::bmm(weights, shapes);                 // eq. 1
  // L_rec (eq. 2): per-vertex L1, mean over scans and vertices.
  const torch::Tensor rec = (rebuilt - target).abs().reshape({B, K, A, 3}).sum(-1).mean({1, 2});
  const float omega = stage == TrainingStage::kEstimation ? m.options.reg_weight : m.options.tuning_reg_weight;
  torch::Tensor loss = (rec + omega * regularization).sum() * loss_scale;
  if (stage == TrainingStage::kEstimation && m.options.amplitude_decay > 0.f && !m.generator->amplitude.is_empty()) {
    // The ridge term once per step over the global batch: this share's part, B / global batch.
    const torch::Tensor ridge = m.generator->amplitude->RidgeTerm();
    loss = loss + ridge * (m.options.amplitude_decay * static_cast<float>(B) * loss_scale);
  }
  loss.backward();
  CopyGradients(m.parameters, m.gradient.data());
  if (reconstruction) *reconstruction = rec.sum().item<double>();
  return loss.item<double>();
}

void BlendshapeGenerator::OptimizerStep(TrainingStage stage) {
  Impl& m = *impl_;
  const int s = static_cast<int>(stage);
  AdamStep step;
  step.step = ++m.steps[s];
  step.learning_rate = m.options.learning_rate;
  const size_t begin = stage == TrainingStage::kEstimation ? 0 : m.estimation_end;
  const size_t end = stage == TrainingStage::kEstimation ? m.estimation_end : m.parameters.size();
  int64_t offset = 0;
  m.DropInference(stage == TrainingStage::kEstimation);
  torch::NoGradGuard no_grad;
  for (size_t k = 0; k < m.parameters.size(); ++k) {
    torch::Tensor& p = m.parameters[k];
    const int64_t n = p.numel();
    if (k >= begin && k < end) {
      step.keep = m.decays[k] ? 1.0 - step.learning_rate * m.options.weight_decay : 1.0;  // AdamW's decoupled decay
      AdamUpdate(step, m.gradient.data() + offset, p.data_ptr<float>(), m.adam_m.data() + offset,
                 m.adam_v.data() + offset, n);
    }
    offset += n;
  }
}

std::vector<float> BlendshapeGenerator::Parameters() const { return FlattenParameters(impl_->parameters); }

void BlendshapeGenerator::SetParameters(const std::vector<float>& parameters) {
  if (static_cast<int64_t>(parameters.size()) != impl_->num_parameters) {
    throw FileIOError("blendshape generator: " + std::to_string(parameters.size()) +
                      " parameters given, the networks have " + std::to_string(impl_->num_parameters));
  }
  impl_->DropInference();
  SetFlatParameters(parameters, &impl_->parameters);
}

void BlendshapeGenerator::FitAmplitudeBasis(const std::vector<const BlendshapePerson*>& people) {
  Impl& m = *impl_;
  if (m.options.amplitude_components <= 0) return;
  Amplitude& amplitude = m.generator->amplitude;
  const int64_t H = m.H(), n = static_cast<int64_t>(people.size()), F = AmplitudeImpl::kFeatures;
  if (n < 2) throw InvalidInputError("blendshape generator: the amplitude's basis needs at least 2 people");
  std::vector<float> images;
  for (const BlendshapePerson* p : people) images.insert(images.end(), p->neutral_image.begin(), p->neutral_image.end());
  torch::NoGradGuard no_grad;
  const torch::Tensor pooled = AmplitudeImpl::Pooled(
      torch::from_blob(images.data(), {n, 3, H, H}, torch::kFloat32)).to(torch::kFloat64).contiguous();
  Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> x(
      pooled.data_ptr<double>(), n, F);
  const Eigen::RowVectorXd mean = x.colwise().mean();
  const Eigen::MatrixXd centered = x.rowwise() - mean;
  // Principal components from the n x n Gram matrix: v_k = C^T u_k / s_k, s_k^2 = lambda_k;
  // whitened so that every component has unit variance over the people: z_k = (x - mean) v_k
  // sqrt(n) / s_k.
  // (Plain loops: the same sums in the same order whatever the thread count.)
  Eigen::MatrixXd gram(n, n);
  for (int64_t a = 0; a < n; ++a) {
    for (int64_t b = 0; b <= a; ++b) gram(a, b) = gram(b, a) = centered.row(a).dot(centered.row(b));
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(gram);
  const int64_t R = m.options.amplitude_components;
  Eigen::MatrixXf basis = Eigen::MatrixXf::Zero(R, F);
  const double largest = eigen.eigenvalues().maxCoeff();
  for (int64_t k = 0; k < std::min(R, n); ++k) {
    const int64_t column = n - 1 - k;  // eigenvalues ascending
    const double lambda = eigen.eigenvalues()[column];
    if (!(lambda > 1e-10 * largest)) break;
    const Eigen::VectorXd v = centered.transpose() * eigen.eigenvectors().col(column) / std::sqrt(lambda);
    basis.row(k) = (v * (std::sqrt(static_cast<double>(n)) / std::sqrt(lambda))).transpose().cast<float>();
  }
  amplitude->mean = torch::from_blob(const_cast<double*>(mean.data()), {F}, torch::kFloat64).to(torch::kFloat32).clone();
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rows = basis;
  amplitude->basis = torch::from_blob(rows.data(), {R, F}, torch::kFloat32).clone();
  m.DropInference();
}

std::vector<float> BlendshapeGenerator::AmplitudeBasis() const {
  const Impl& m = *impl_;
  if (m.options.amplitude_components <= 0) return {};
  const Amplitude& amplitude = m.generator->amplitude;
  const torch::Tensor all = torch::cat({amplitude->mean.unsqueeze(0), amplitude->basis}, 0).contiguous();
  return std::vector<float>(all.data_ptr<float>(), all.data_ptr<float>() + all.numel());
}

void BlendshapeGenerator::SetAmplitudeBasis(const std::vector<float>& basis) {
  Impl& m = *impl_;
  const int64_t R = m.options.amplitude_components, F = AmplitudeImpl::kFeatures;
  if (R <= 0 && basis.empty()) return;
  if (static_cast<int64_t>(basis.size()) != (R + 1) * F) {
    throw FileIOError("blendshape generator: the amplitude basis holds " + std::to_string(basis.size()) +
                      " values, the model needs " + std::to_string((R + 1) * F));
  }
  Amplitude& amplitude = m.generator->amplitude;
  const torch::Tensor all = torch::from_blob(const_cast<float*>(basis.data()), {R + 1, F}, torch::kFloat32).clone();
  amplitude->mean = all[0].clone();
  amplitude->basis = all.narrow(0, 1, R).clone();
  m.DropInference();
}

std::vector<float> BlendshapeGenerator::State() const {
  std::vector<float> state = Parameters();
  state.insert(state.end(), impl_->adam_m.begin(), impl_->adam_m.end());
  state.insert(state.end(), impl_->adam_v.begin(), impl_->adam_v.end());
  state.push_back(static_cast<float>(impl_->steps[0]));
  state.push_back(static_cast<float>(impl_->steps[1]));
  return state;
}

void BlendshapeGenerator::SetState(const std::vector<float>& state) {
  Impl& m = *impl_;
  const int64_t n = m.num_parameters;
  if (static_cast<int64_t>(state.size()) != 3 * n + 2) {
    throw FileIOError("blendshape generator: checkpoint state has the wrong size");
  }
  SetParameters(std::vector<float>(state.begin(), state.begin() + n));
  std::copy(state.begin() + n, state.begin() + 2 * n, m.adam_m.begin());
  std::copy(state.begin() + 2 * n, state.begin() + 3 * n, m.adam_v.begin());
  m.steps[0] = static_cast<int64_t>(state[3 * n]);
  m.steps[1] = static_cast<int64_t>(state[3 * n + 1]);
}

std::vector<float> BlendshapeGenerator::PredictOffsets(const std::vector<float>& neutral_image,
                                                       bool tuned) const {
  Impl& m = *impl_;  // modules' forward is not const
  const int64_t H = m.H(), N = m.N(), A = m.A();
  if (static_cast<int64_t>(neutral_image.size()) != 3 * H * H) {
    throw InvalidInputError("blendshape generator: neutral image has the wrong size");
  }
  const std::shared_ptr<const Impl::Inference> form = m.InferenceForm();
  const Impl::Inference& f = *form;
  torch::NoGradGuard no_grad;
  const torch::Tensor input = m.WithStatic(torch::from_blob(const_cast<float*>(neutral_image.data()),
                                                            {1, 3, H, H}, torch::kFloat32));
  const torch::Tensor generator_features = f.generator->Features(input);
  torch::Tensor tuning_features, tuning_input;
  if (tuned) {
    torch::Tensor initial = ToDense(f.offsets_in(ToNet(generator_features, f.onednn))).contiguous();
    ReluInPlace(initial);
    tuning_input = torch::cat({input, initial}, 1);
    tuning_features = f.tuning->Features(tuning_input);
  }
  // Bilinear samples of the features at the chart vertices as a [1, rows, 1, A] image, with a
  // row of the stencil weights' sums after each generator's features (the biases' channel).
  const int64_t fg = f.generator_features, ft = f.tuning_features;
  const int64_t rows = tuned ? fg + 1 + ft + 1 : fg + 1;
  torch::Tensor sampled = torch::empty({1, rows, 1, A}, torch::kFloat32);
  const int32_t* pixels = m.geometry->sample_pixels.data();
  const float* weights = m.geometry->sample_weights.data();
  auto sample = [&](const torch::Tensor& features, int64_t channels, int64_t first_row) {
    const float* data = features.data_ptr<float>();
    for (int64_t c = 0; c < channels; ++c) {
      const float* image = data + c * H * H;
      float* row = sampled.data_ptr<float>() + (first_row + c) * A;
      for (int64_t k = 0; k < A; ++k) {
        const int32_t* p = pixels + 4 * k;
        const float* w = weights + 4 * k;
        row[k] = w[0] * image[p[0]] + w[1] * image[p[1]] + w[2] * image[p[2]] + w[3] * image[p[3]];
      }
    }
    float* ones = sampled.data_ptr<float>() + (first_row + channels) * A;
    for (int64_t k = 0; k < A; ++k) {
      const float* w = weights + 4 * k;
      ones[k] = w[0] + w[1] + w[2] + w[3];
    }
  };
  sample(generator_features, fg, 0);
  if (tuned) sample(tuning_features, ft, fg + 1);
  // [1, 3N, 1, A]: channel 3 i + d, vertex k; written as [N, A, 3].
  const torch::Tensor offsets = ToDense((tuned ? f.output_tuned : f.output)(ToNet(sampled, f.onednn))).contiguous();
  std::vector<float> out(static_cast<size_t>(N) * A * 3);
  const float* y = offsets.data_ptr<float>();
  for (int64_t i = 0; i < N; ++i) {
    for (int64_t d = 0; d < 3; ++d) {
      const float* channel = y + (3 * i + d) * A;
      float* o = out.data() + i * A * 3 + d;
      for (int64_t k = 0; k < A; ++k) o[3 * k] = channel[k];
    }
  }
  // The heads, on the same samples of the features; their offsets along the template motion
  // apart when the amplitude scales only those.
  const bool on_path = m.options.amplitude_on_path && !m.generator->amplitude.is_empty();
  std::vector<float> along_path(on_path ? out.size() : 0, 0.f);
  float* along = on_path ? along_path.data() : out.data();
  if (!f.generator_heads->heads.empty()) {
    const torch::Tensor samples = m.SampleChannels(input).contiguous();
    f.generator_heads->Add(sampled.data_ptr<float>(), samples.data_ptr<float>(), samples.size(1), A, out.data(), along);
  }
  if (tuned && !f.tuning_heads->heads.empty()) {
    const torch::Tensor samples = m.SampleChannels(tuning_input).contiguous();
    f.tuning_heads->Add(sampled.data_ptr<float>() + (fg + 1) * A, samples.data_ptr<float>(), samples.size(1), A,
                        out.data(), along);
  }
  // The amplitude: out_i = (1 + a_i)(S_i + out_i) - S_i, or with amplitude_on_path
  // out_i = free_i + (1 + a_i)(S_i + along_i) - S_i.
  if (!m.generator->amplitude.is_empty()) {
    const torch::Tensor a = m.generator->amplitude->forward(input).contiguous();
    const float* amplitude = a.data_ptr<float>();
    const float* S = m.geometry->template_deltas.data();
    const float* scaled = on_path ? along_path.data() : out.data();  // what a_i multiplies
    for (int64_t i = 0; i < N; ++i) {
      for (int64_t j = i * A * 3; j < (i + 1) * A * 3; ++j) {
        out[j] += (on_path ? along_path[j] : 0.f) + amplitude[i] * (S[j] + scaled[j]);
      }
    }
  }
  return out;
}

void BlendshapeGenerator::PrepareInference() const {
  const int64_t H = impl_->H();
  PredictOffsets(std::vector<float>(static_cast<size_t>(3 * H * H), 0.f), true);
}

std::vector<float> BlendshapeGenerator::PredictOffsetsWithModules(const std::vector<float>& neutral_image,
                                                                  bool tuned) const {
  Impl& m = *impl_;
  torch::NoGradGuard no_grad;
  const int64_t H = m.H();
  if (static_cast<int64_t>(neutral_image.size()) != 3 * H * H) {
    throw InvalidInputError("blendshape generator: neutral image has the wrong size");
  }
  const torch::Tensor input = m.WithStatic(torch::from_blob(const_cast<float*>(neutral_image.data()),
                                                            {1, 3, H, H}, torch::kFloat32));
  const GeneratorOutput estimation = m.generator->forward(input);
  const torch::Tensor amplitude = m.AmplitudeOf(input);
  torch::Tensor offsets = m.Amplified(m.Offsets(m.generator, estimation), amplitude);
  if (tuned) offsets = offsets + m.Scaled(m.Offsets(m.tuning, m.TuningForward(input, estimation)), amplitude);
  offsets = offsets.contiguous();
  return std::vector<float>(offsets.data_ptr<float>(), offsets.data_ptr<float>() + offsets.numel());
}

}  // namespace facecap::nn
