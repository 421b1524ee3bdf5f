#include "contour/contours.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include <opencv2/imgproc.hpp>

namespace facecap::contour {

std::vector<int16_t> ClassifyPixels(const Image8& image, const Palette& palette) {
  const int n = palette.num_labels();
  std::vector<std::array<float, 3>> colors(palette.colors);
  colors.push_back({0.f, 0.f, 0.f});
  // Later labels win ties only when strictly closer, so a black region loses to the background.
  std::vector<int> order(n);
  for (int i = 0; i < n; ++i) order[i] = i;
  std::swap(order[0], order[n - 1]);  // the background first
  std::vector<int16_t> labels(static_cast<size_t>(image.width) * image.height);
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const uint8_t* p = image.pixel(x, y);
      float best = std::numeric_limits<float>::max();
      int best_label = palette.background();
      for (int l : order) {
        float d = 0;
        for (int c = 0; c < 3; ++c) {
          const float diff = p[c] - 255.f * colors[l][c];
          d += diff * diff;
        }
        if (d < best) {
          best = d;
          best_label = l;
        }
      }
      labels[static_cast<size_t>(y) * image.width + x] = static_cast<int16_t>(best_label);
    }
  }
  return labels;
}

std::vector<Border> ExtractBorders(const std::vector<int16_t>& labels, int width, int height,
                                   int num_labels, const BorderOptions& options) {
  std::vector<Border> borders;
  auto label_at = [&](int x, int y) -> int {
    if (x < 0 || y < 0 || x >= width || y >= height) return -1;
    return labels[static_cast<size_t>(y) * width + x];
  };
  for (int region = 0; region < num_labels; ++region) {
    cv::Mat mask(height, width, CV_8U, cv::Scalar(0));
    bool any = false;
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        if (label_at(x, y) == region) {
          mask.at<uint8_t>(y, x) = 255;
          any = true;
        }
      }
    }
    if (!any) continue;
    std::vector<std::vector<cv::Point>> outlines;
    cv::findContours(mask, outlines, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);
    for (const auto& outline : outlines) {
      const int n = static_cast<int>(outline.size());
      if (n == 0) continue;
      // The label across the border at each outline pixel: the first 4-neighbour outside the
      // region, the largest label preferred so region pairs are named the same from both sides.
      std::vector<int> across(n, -1);
      for (int i = 0; i < n; ++i) {
        const cv::Point& p = outline[i];
        int best = -1;
        for (const auto& d : {cv::Point(1, 0), cv::Point(-1, 0), cv::Point(0, 1), cv::Point(0, -1)}) {
          const int l = label_at(p.x + d.x, p.y + d.y);
          if (l >= 0 && l != region) best = std::max(best, l);
        }
        across[i] = best;
      }
      // Runs of equal `across`; a run may wrap around the end of the closed outline.
      int start = 0;
      while (start < n && across[start] == across[(start + n - 1) % n]) ++start;
      const bool single = start == n;
      if (single) start = 0;
      for (int i = 0; i < n;) {
        const int first = (start + i) % n;
        const int label = across[first];
        int length = 1;
        while (i + length < n && across[(start + i + length) % n] == label) ++length;
        if (label > region && length >= options.min_points) {
          Border b;
          b.region = region;
          b.neighbor = label;
          b.closed = single;
          for (int k = 0; k < length; ++k) {
            const cv::Point& p = outline[(first + k) % n];
            b.points.push_back({p.x + 0.5f, p.y + 0.5f});
          }
          borders.push_back(std::move(b));
        }
        i += length;
      }
    }
  }
  return borders;
}

Image8 DrawBorders(const Image8& frame, const std::vector<Border>& borders, const Palette& palette,
                   int scale) {
  scale = std::max(1, scale);
  cv::Mat src(frame.height, frame.width, CV_8UC3, const_cast<uint8_t*>(frame.data.data()));
  cv::Mat big;
  cv::resize(src, big, cv::Size(frame.width * scale, frame.height * scale), 0, 0, cv::INTER_NEAREST);
  for (const Border& b : borders) {
    const int label = b.neighbor == palette.background() ? b.region : b.neighbor;
    if (label >= static_cast<int>(palette.colors.size())) continue;
    const auto& c = palette.colors[label];
    std::vector<cv::Point> points;
    for (const auto& p : b.points) {
      points.emplace_back(static_cast<int>(std::lround(p[0] * scale)),
                          static_cast<int>(std::lround(p[1] * scale)));
    }
    const cv::Scalar color(255 * c[0], 255 * c[1], 255 * c[2]);  // the buffer is RGB
    cv::polylines(big, points, b.closed, color, std::max(1, scale / 3), cv::LINE_AA);
  }
  Image8 out(big.cols, big.rows, 3);
  for (int y = 0; y < big.rows; ++y) std::memcpy(out.pixel(0, y), big.ptr(y), big.cols * 3);
  return out;
}

void IouCounts::Add(const std::vector<int16_t>& predicted, const std::vector<int16_t>& truth) {
  for (size_t i = 0; i < truth.size(); ++i) {
    const int p = predicted[i], t = truth[i];
    if (p == t) {
      ++intersection[t];
      ++union_[t];
    } else {
      ++union_[t];
      ++union_[p];
    }
  }
}

double IouCounts::Iou(int label) const {
  if (union_[label] == 0) return -1;
  return static_cast<double>(intersection[label]) / union_[label];
}

}  // namespace facecap::contour
