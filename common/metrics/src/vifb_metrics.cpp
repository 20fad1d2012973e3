#include "thermovis/metrics/vifb_metrics.hpp"

#include <cmath>
#include <complex>
#include <functional>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace thermovis::metrics {
namespace {

using Complex = std::complex<double>;

constexpr std::array<std::string_view, kMetricCount> kNames = {
    "CE", "EN", "MI", "PSNR", "AG", "EI", "Qabf", "SD", "SF", "RMSE", "SSIM", "Qcb", "Qcv"};

// MATLAB's round(): half away from zero.
double matlab_round(double x) { return std::round(x); }

// MATLAB rgb2gray on uint8 data (coefficients of rgb2gray.m), rounded back to 8 bits. `bgr` is
// CV_8UC3 in OpenCV order; the result is CV_64FC1 holding integers 0..255.
cv::Mat matlab_rgb2gray(const cv::Mat& bgr) {
  cv::Mat gray(bgr.size(), CV_64FC1);
  for (int r = 0; r < bgr.rows; ++r) {
    const auto* s = bgr.ptr<cv::Vec3b>(r);
    auto* d = gray.ptr<double>(r);
    for (int c = 0; c < bgr.cols; ++c) {
      const double v =
          0.298936021293775 * s[c][2] + 0.587043074451121 * s[c][1] + 0.114020904255103 * s[c][0];
      d[c] = std::min(255.0, matlab_round(v));
    }
  }
  return gray;
}

// Channel k of an 8-bit image as CV_64F, in MATLAB's RGB channel order (k = 0 is red).
cv::Mat rgb_channel(const cv::Mat& image, int k) {
  cv::Mat plane;
  if (image.channels() == 1) {
    plane = image;
  } else {
    cv::extractChannel(image, plane, 2 - k);
  }
  cv::Mat out;
  plane.convertTo(out, CV_64F);
  return out;
}

// One channel triple (visible, infrared, fused), each CV_64FC1 with values 0..255.
struct Planes {
  cv::Mat vis, ir, fused;
};

// VIFB's per-channel dispatch (the b == 1 / b1 == 1 / else branches of every metric file).
std::vector<Planes> channel_triples(const cv::Mat& vis, const cv::Mat& ir, const cv::Mat& fused) {
  std::vector<Planes> out;
  if (fused.channels() == 1) {
    const auto gray = [](const cv::Mat& m) {
      if (m.channels() == 3) return matlab_rgb2gray(m);
      cv::Mat d;
      m.convertTo(d, CV_64F);
      return d;
    };
    out.push_back({gray(vis), gray(ir), rgb_channel(fused, 0)});
    return out;
  }
  for (int k = 0; k < 3; ++k) {
    out.push_back(
        {rgb_channel(vis, k), rgb_channel(ir, ir.channels() == 1 ? 0 : k), rgb_channel(fused, k)});
  }
  return out;
}

double mean_over_channels(const std::vector<Planes>& triples,
                          const std::function<double(const Planes&)>& f) {
  double sum = 0.0;
  for (const auto& t : triples) sum += f(t);
  return sum / static_cast<double>(triples.size());
}

// 256-bin histogram of integer-valued data 0..255 (floor of the value, as VIFB indexes).
std::array<double, 256> histogram(const cv::Mat& plane) {
  std::array<double, 256> h{};
  for (int r = 0; r < plane.rows; ++r) {
    const auto* p = plane.ptr<double>(r);
    for (int c = 0; c < plane.cols; ++c) {
      h[static_cast<std::size_t>(std::clamp(std::floor(p[c]), 0.0, 255.0))] += 1.0;
    }
  }
  return h;
}

// metricsCross_entropy.m: KL divergence (log2) of the source's histogram from the fused one,
// over bins where both are nonzero.
double cross_entropy(const cv::Mat& source, const cv::Mat& fused) {
  const auto h1 = histogram(source);
  const auto h2 = histogram(fused);
  const double n = static_cast<double>(source.total());
  double result = 0.0;
  for (std::size_t k = 0; k < 256; ++k) {
    const double p1 = h1[k] / n;
    const double p2 = h2[k] / n;
    if (p1 != 0.0 && p2 != 0.0) result += p1 * std::log2(p1 / p2);
  }
  return result;
}

double entropy(const cv::Mat& plane) {
  const auto h = histogram(plane);
  const double n = static_cast<double>(plane.total());
  double result = 0.0;
  for (double count : h) {
    if (count > 0.0) result -= (count / n) * std::log2(count / n);
  }
  return result;
}

// metricsMutinf.m's mutinf(a, b): min-max rescale each to 0..255 (int16 rounding), joint
// histogram, natural logarithms.
double mutual_information(const cv::Mat& a, const cv::Mat& b) {
  const auto bins = [](const cv::Mat& m) {
    double lo = 0.0, hi = 0.0;
    cv::minMaxLoc(m, &lo, &hi);
    std::vector<int> idx(m.total(), 0);
    if (hi != lo) {
      std::size_t i = 0;
      for (int r = 0; r < m.rows; ++r) {
        const auto* p = m.ptr<double>(r);
        for (int c = 0; c < m.cols; ++c) {
          idx[i++] = static_cast<int>(matlab_round((p[c] - lo) / (hi - lo) * 255.0));
        }
      }
    }
    return idx;
  };
  const auto ia = bins(a);
  const auto ib = bins(b);
  std::vector<double> joint(256 * 256, 0.0);
  std::array<double, 256> ha{}, hb{};
  for (std::size_t i = 0; i < ia.size(); ++i) {
    joint[static_cast<std::size_t>(ia[i] * 256 + ib[i])] += 1.0;
    ha[static_cast<std::size_t>(ia[i])] += 1.0;
    hb[static_cast<std::size_t>(ib[i])] += 1.0;
  }
  const double n = static_cast<double>(ia.size());
  const auto h = [n](auto begin, auto end) {
    double s = 0.0;
    for (auto it = begin; it != end; ++it) {
      if (*it > 0.0) s -= (*it / n) * std::log(*it / n);
    }
    return s;
  };
  return h(ha.begin(), ha.end()) + h(hb.begin(), hb.end()) - h(joint.begin(), joint.end());
}

// VIFB's "mse": sqrt(sum of squared differences) / (M N) (a known bug, kept for agreement).
double vifb_mse(const cv::Mat& a, const cv::Mat& b) {
  return std::sqrt(cv::norm(a, b, cv::NORM_L2SQR)) / static_cast<double>(a.total());
}

// MATLAB gradient(): central differences inside, one-sided at the borders.
double average_gradient(const cv::Mat& f) {
  const int rows = f.rows, cols = f.cols;
  const auto at = [&f](int r, int c) { return f.at<double>(r, c); };
  double sum = 0.0;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      double dx = 0.0, dy = 0.0;
      if (cols > 1) {
        if (c == 0)
          dx = at(r, 1) - at(r, 0);
        else if (c == cols - 1)
          dx = at(r, c) - at(r, c - 1);
        else
          dx = 0.5 * (at(r, c + 1) - at(r, c - 1));
      }
      if (rows > 1) {
        if (r == 0)
          dy = at(1, c) - at(0, c);
        else if (r == rows - 1)
          dy = at(r, c) - at(r - 1, c);
        else
          dy = 0.5 * (at(r + 1, c) - at(r - 1, c));
      }
      sum += std::sqrt((dx * dx + dy * dy) / 2.0);
    }
  }
  return sum / (static_cast<double>(rows - 1) * static_cast<double>(cols - 1));
}

// metricsEdge_intensity.m: Sobel magnitude with 'replicate' borders, mean over pixels.
double edge_intensity(const cv::Mat& f) {
  cv::Mat gx, gy, mag;
  cv::Sobel(f, gx, CV_64F, 1, 0, 3, 1.0, 0.0, cv::BORDER_REPLICATE);
  cv::Sobel(f, gy, CV_64F, 0, 1, 3, 1.0, 0.0, cv::BORDER_REPLICATE);
  cv::magnitude(gx, gy, mag);
  return cv::mean(mag)[0];
}

// Zero-padded 3x3 Sobel responses of conv2(.., 'same') / filter2(.., 'same'). The sign of both
// responses is irrelevant to every use below (magnitudes and y/x ratios).
void sobel_zero_padded(const cv::Mat& p, cv::Mat& gx, cv::Mat& gy) {
  cv::Sobel(p, gx, CV_64F, 1, 0, 3, 1.0, 0.0, cv::BORDER_CONSTANT);
  cv::Sobel(p, gy, CV_64F, 0, 1, 3, 1.0, 0.0, cv::BORDER_CONSTANT);
}

// metricsQabf.m (Xydeas & Petrovic), on images scaled by 255 as VIFB's code leaves them.
double qabf(const cv::Mat& a, const cv::Mat& b, const cv::Mat& f) {
  constexpr double Tg = 0.9994, kg = -15, Dg = 0.5, Ta = 0.9879, ka = -22, Da = 0.8;
  constexpr double half_pi = std::numbers::pi / 2.0;
  struct Edges {
    cv::Mat g, angle;
  };
  const auto edges = [](const cv::Mat& img) {
    cv::Mat gx, gy;
    sobel_zero_padded(img * 255.0, gx, gy);
    Edges e{cv::Mat(img.size(), CV_64F), cv::Mat(img.size(), CV_64F)};
    for (int r = 0; r < img.rows; ++r) {
      const auto* x = gx.ptr<double>(r);
      const auto* y = gy.ptr<double>(r);
      auto* g = e.g.ptr<double>(r);
      auto* an = e.angle.ptr<double>(r);
      for (int c = 0; c < img.cols; ++c) {
        g[c] = std::sqrt(x[c] * x[c] + y[c] * y[c]);
        an[c] = x[c] == 0.0 ? half_pi : std::atan(y[c] / x[c]);
      }
    }
    return e;
  };
  const Edges ea = edges(a), eb = edges(b), ef = edges(f);
  const auto preservation = [&](double gs, double as, double gf, double af) {
    double G = 0.0;
    if (gs > gf)
      G = gf / gs;
    else if (gs == gf)
      G = gf;  // VIFB's branch: the magnitude itself, not 1
    else
      G = gs / gf;
    const double A = 1.0 - std::abs(as - af) / half_pi;
    return Tg / (1.0 + std::exp(kg * (G - Dg))) * Ta / (1.0 + std::exp(ka * (A - Da)));
  };
  double num = 0.0, den = 0.0;
  for (int r = 0; r < a.rows; ++r) {
    for (int c = 0; c < a.cols; ++c) {
      const double gA = ea.g.at<double>(r, c), gB = eb.g.at<double>(r, c);
      const double gF = ef.g.at<double>(r, c), aF = ef.angle.at<double>(r, c);
      num += preservation(gA, ea.angle.at<double>(r, c), gF, aF) * gA +
             preservation(gB, eb.angle.at<double>(r, c), gF, aF) * gB;
      den += gA + gB;
    }
  }
  return num / den;
}

double population_sd(const cv::Mat& f) {
  cv::Scalar mean, sd;
  cv::meanStdDev(f, mean, sd);
  return sd[0];
}

// metricsSpatial_frequency.m on the m x (n b) matrix of channels laid side by side (R | G | B).
double spatial_frequency(const cv::Mat& fused) {
  std::vector<cv::Mat> planes;
  for (int k = 0; k < fused.channels(); ++k) planes.push_back(rgb_channel(fused, k));
  cv::Mat wide;
  cv::hconcat(planes, wide);
  double rf = 0.0, cf = 0.0;
  for (int r = 0; r < wide.rows; ++r) {
    const auto* p = wide.ptr<double>(r);
    for (int c = 1; c < wide.cols; ++c) rf += (p[c] - p[c - 1]) * (p[c] - p[c - 1]);
    if (r > 0) {
      const auto* q = wide.ptr<double>(r - 1);
      for (int c = 0; c < wide.cols; ++c) cf += (p[c] - q[c]) * (p[c] - q[c]);
    }
  }
  const double n = static_cast<double>(wide.total());
  return std::sqrt(rf / n + cf / n);
}

// metricsSsim.m's ssim(): 11x11 Gaussian window (sigma 1.5), 'valid' region, L = 255.
double ssim(const cv::Mat& a, const cv::Mat& b) {
  constexpr int kWin = 11;
  if (a.rows < kWin || a.cols < kWin)
    throw std::invalid_argument("SSIM needs images of 11x11 or more");
  const cv::Mat g = cv::getGaussianKernel(kWin, 1.5, CV_64F);
  const cv::Rect valid(kWin / 2, kWin / 2, a.cols - kWin + 1, a.rows - kWin + 1);
  const auto filt = [&](const cv::Mat& m) {
    cv::Mat out;
    cv::sepFilter2D(m, out, CV_64F, g, g, cv::Point(-1, -1), 0.0, cv::BORDER_CONSTANT);
    return cv::Mat(out, valid);
  };
  const double C1 = (0.01 * 255) * (0.01 * 255), C2 = (0.03 * 255) * (0.03 * 255);
  const cv::Mat ua = filt(a), ub = filt(b);
  const cv::Mat saa = filt(a.mul(a)) - ua.mul(ua);
  const cv::Mat sbb = filt(b.mul(b)) - ub.mul(ub);
  const cv::Mat sab = filt(a.mul(b)) - ua.mul(ub);
  cv::Mat num = (2 * ua.mul(ub) + C1).mul(2 * sab + C2);
  cv::Mat den = (ua.mul(ua) + ub.mul(ub) + C1).mul(saa + sbb + C2);
  cv::Mat map;
  cv::divide(num, den, map);
  return cv::mean(map)[0];
}

// normalize1.m: min-max to 0..255, rounded; an all-zero image stays as it is.
cv::Mat normalize1(const cv::Mat& m) {
  double lo = 0.0, hi = 0.0;
  cv::minMaxLoc(m, &lo, &hi);
  if (hi == 0.0 && lo == 0.0) return m.clone();
  cv::Mat out(m.size(), CV_64F);
  for (int r = 0; r < m.rows; ++r) {
    const auto* p = m.ptr<double>(r);
    auto* d = out.ptr<double>(r);
    // MATLAB divides by zero here for a constant nonzero image (NaN); keep that behaviour.
    for (int c = 0; c < m.cols; ++c) d[c] = matlab_round((p[c] - lo) / (hi - lo) * 255.0);
  }
  return out;
}

// Frequency of DFT index k (0..n-1) on MATLAB's freqspace grid after ifftshift, in freqspace
// units (-1..1).
double freqspace_at(int k, int n) {
  const int half = n / 2;
  return static_cast<double>(((k + half) % n) - half) * 2.0 / static_cast<double>(n);
}

// ifft2(ifftshift(fftshift(fft2(image)) .* H)) for a radial frequency response H(r), with
// r = sqrt((u * cols / scale)^2 + (v * rows / scale)^2) on freqspace's grid. Returns CV_64FC2.
cv::Mat radial_filter(const cv::Mat& image, double scale, const std::function<double(double)>& H) {
  cv::Mat spectrum;
  cv::dft(image, spectrum, cv::DFT_COMPLEX_OUTPUT);
  const int rows = image.rows, cols = image.cols;
  std::vector<double> u(static_cast<std::size_t>(cols));
  for (int c = 0; c < cols; ++c)
    u[static_cast<std::size_t>(c)] = freqspace_at(c, cols) * cols / scale;
  for (int r = 0; r < rows; ++r) {
    const double v = freqspace_at(r, rows) * rows / scale;
    auto* s = spectrum.ptr<cv::Vec2d>(r);
    for (int c = 0; c < cols; ++c) {
      const double uu = u[static_cast<std::size_t>(c)];
      const double h = H(std::sqrt(uu * uu + v * v));
      s[c][0] *= h;
      s[c][1] *= h;
    }
  }
  cv::Mat out;
  cv::idft(spectrum, out, cv::DFT_COMPLEX_OUTPUT | cv::DFT_SCALE);
  return out;
}

// metricsQcb.m (Chen & Blum).
double qcb(const cv::Mat& im1, const cv::Mat& im2, const cv::Mat& fused) {
  constexpr double f0 = 15.3870, f1 = 1.3456, a = 0.7622, p = 3, q = 2, Z = 0.0001;
  const auto Sd = [&](double r) {
    return std::exp(-(r / f0) * (r / f0)) - a * std::exp(-(r / f1) * (r / f1));
  };
  // The unnormalised 31x31 Gaussian of gaussian2d(): separable as g(x) g(y) / (2 pi sigma^2).
  const auto kernel = [](double sigma) {
    cv::Mat k(31, 1, CV_64F);
    for (int i = 0; i < 31; ++i) {
      const double x = i - 15;
      k.at<double>(i) =
          std::exp(-x * x / (2 * sigma * sigma)) / std::sqrt(2 * std::numbers::pi) / sigma;
    }
    return k;
  };
  const cv::Mat k1 = kernel(2.0), k2 = kernel(4.0);
  const auto contrast_power = [&](const cv::Mat& img) {
    const cv::Mat filtered = radial_filter(normalize1(img), 30.0, Sd);
    cv::Mat b1, b2;
    cv::sepFilter2D(filtered, b1, CV_64F, k1, k1, cv::Point(-1, -1), 0.0, cv::BORDER_CONSTANT);
    cv::sepFilter2D(filtered, b2, CV_64F, k2, k2, cv::Point(-1, -1), 0.0, cv::BORDER_CONSTANT);
    cv::Mat cp(img.size(), CV_64F);
    for (int r = 0; r < img.rows; ++r) {
      const auto* x = b1.ptr<cv::Vec2d>(r);
      const auto* y = b2.ptr<cv::Vec2d>(r);
      auto* d = cp.ptr<double>(r);
      for (int c = 0; c < img.cols; ++c) {
        const double C = std::abs(Complex(x[c][0], x[c][1]) / Complex(y[c][0], y[c][1]) - 1.0);
        d[c] = std::pow(C, p) / (std::pow(C, q) + Z);
      }
    }
    return cp;
  };
  const cv::Mat c1 = contrast_power(im1), c2 = contrast_power(im2), cf = contrast_power(fused);
  double sum = 0.0;
  for (int r = 0; r < im1.rows; ++r) {
    for (int c = 0; c < im1.cols; ++c) {
      const double x1 = c1.at<double>(r, c), x2 = c2.at<double>(r, c), xf = cf.at<double>(r, c);
      const double q1 = x1 < xf ? x1 / xf : xf / x1;
      const double q2 = x2 < xf ? x2 / xf : xf / x2;
      const double l1 = x1 * x1 / (x1 * x1 + x2 * x2);
      const double l2 = x2 * x2 / (x1 * x1 + x2 * x2);
      sum += l1 * q1 + l2 * q2;
    }
  }
  return sum / static_cast<double>(im1.total());
}

// metricsQcv.m (Chen & Varshney), with blkproc's zero padding of partial 16x16 blocks.
double qcv(const cv::Mat& im1_in, const cv::Mat& im2_in, const cv::Mat& fused_in) {
  constexpr int kBlock = 16;
  constexpr double alpha = 5;
  const cv::Mat im1 = normalize1(im1_in), im2 = normalize1(im2_in), fused = normalize1(fused_in);
  const int rows = im1.rows, cols = im1.cols;
  const int brows = (rows + kBlock - 1) / kBlock, bcols = (cols + kBlock - 1) / kBlock;
  const auto saliency = [&](const cv::Mat& img) {
    cv::Mat gx, gy, g;
    sobel_zero_padded(img * 255.0, gx, gy);
    cv::magnitude(gx, gy, g);
    cv::Mat s = cv::Mat::zeros(brows, bcols, CV_64F);
    for (int r = 0; r < rows; ++r) {
      for (int c = 0; c < cols; ++c)
        s.at<double>(r / kBlock, c / kBlock) += std::pow(g.at<double>(r, c), alpha);
    }
    return s;
  };
  const auto theta_m = [](double r) {
    return 2.6 * (0.0192 + 0.144 * r) * std::exp(-std::pow(0.144 * r, 1.1));
  };
  const auto distortion = [&](const cv::Mat& img) {
    const cv::Mat df = radial_filter(img - fused, 8.0, theta_m);
    cv::Mat d(brows, bcols, CV_64FC2, cv::Scalar::all(0));
    for (int r = 0; r < rows; ++r) {
      for (int c = 0; c < cols; ++c) {
        const cv::Vec2d z = df.at<cv::Vec2d>(r, c);
        const Complex sq = Complex(z[0], z[1]) * Complex(z[0], z[1]);
        auto& cell = d.at<cv::Vec2d>(r / kBlock, c / kBlock);
        cell[0] += sq.real() / (kBlock * kBlock);
        cell[1] += sq.imag() / (kBlock * kBlock);
      }
    }
    return d;
  };
  const cv::Mat l1 = saliency(im1), l2 = saliency(im2);
  const cv::Mat d1 = distortion(im1), d2 = distortion(im2);
  double num = 0.0, den = 0.0;
  for (int r = 0; r < brows; ++r) {
    for (int c = 0; c < bcols; ++c) {
      num += l1.at<double>(r, c) * d1.at<cv::Vec2d>(r, c)[0] +
             l2.at<double>(r, c) * d2.at<cv::Vec2d>(r, c)[0];
      den += l1.at<double>(r, c) + l2.at<double>(r, c);
    }
  }
  return num / den;
}

void check_inputs(const cv::Mat& vis, const cv::Mat& ir, const cv::Mat& fused) {
  const auto check = [](const cv::Mat& m, const char* what) {
    if (m.empty()) throw std::invalid_argument(std::string(what) + " image is empty");
    if (m.depth() != CV_8U || (m.channels() != 1 && m.channels() != 3)) {
      throw std::invalid_argument(std::string(what) +
                                  " image must be 8-bit with 1 or 3 channels (got type " +
                                  cv::typeToString(m.type()) + ")");
    }
  };
  check(vis, "visible");
  check(ir, "infrared");
  check(fused, "fused");
  if (vis.size() != fused.size() || ir.size() != fused.size()) {
    throw std::invalid_argument("metric images differ in size: visible " +
                                std::to_string(vis.cols) + "x" + std::to_string(vis.rows) +
                                ", infrared " + std::to_string(ir.cols) + "x" +
                                std::to_string(ir.rows) + ", fused " + std::to_string(fused.cols) +
                                "x" + std::to_string(fused.rows));
  }
  if (fused.channels() == 3 && vis.channels() != 3) {
    throw std::invalid_argument("a colour fused image needs a colour visible image");
  }
  if (fused.rows < 2 || fused.cols < 2)
    throw std::invalid_argument("metric images need 2x2 pixels or more");
}

}  // namespace

const std::array<Metric, kMetricCount>& all_metrics() {
  static const std::array<Metric, kMetricCount> all = {
      Metric::CE, Metric::EN, Metric::MI,   Metric::PSNR, Metric::AG,  Metric::EI, Metric::Qabf,
      Metric::SD, Metric::SF, Metric::RMSE, Metric::SSIM, Metric::Qcb, Metric::Qcv};
  return all;
}

std::string_view metric_name(Metric metric) { return kNames[static_cast<std::size_t>(metric)]; }

std::optional<Metric> metric_from_name(std::string_view name) {
  for (Metric m : all_metrics()) {
    if (metric_name(m) == name) return m;
  }
  return std::nullopt;
}

bool higher_is_better(Metric metric) {
  return metric != Metric::CE && metric != Metric::RMSE && metric != Metric::Qcv;
}

double vifb_metric(Metric metric, const cv::Mat& visible, const cv::Mat& infrared,
                   const cv::Mat& fused) {
  check_inputs(visible, infrared, fused);
  const auto triples = channel_triples(visible, infrared, fused);
  const auto per_channel = [&](const std::function<double(const Planes&)>& f) {
    return mean_over_channels(triples, f);
  };
  switch (metric) {
    case Metric::CE:
      return per_channel([](const Planes& t) {
        return (cross_entropy(t.vis, t.fused) + cross_entropy(t.ir, t.fused)) / 2.0;
      });
    case Metric::EN:
      return per_channel([](const Planes& t) { return entropy(t.fused); });
    case Metric::MI:
      return per_channel([](const Planes& t) {
        return mutual_information(t.vis, t.fused) + mutual_information(t.ir, t.fused);
      });
    case Metric::PSNR:
      return per_channel([](const Planes& t) {
        const double mse = (vifb_mse(t.vis, t.fused) + vifb_mse(t.ir, t.fused)) / 2.0;
        return 20.0 * std::log10(255.0 / std::sqrt(mse));
      });
    case Metric::RMSE:
      return per_channel([](const Planes& t) {
        return (vifb_mse(t.vis, t.fused) + vifb_mse(t.ir, t.fused)) / 2.0;
      });
    case Metric::AG:
      return per_channel([](const Planes& t) { return average_gradient(t.fused); });
    case Metric::EI:
      return per_channel([](const Planes& t) { return edge_intensity(t.fused); });
    case Metric::Qabf:
      return per_channel([](const Planes& t) { return qabf(t.vis, t.ir, t.fused); });
    case Metric::SD:
      return per_channel([](const Planes& t) { return population_sd(t.fused); });
    case Metric::SF:
      return spatial_frequency(fused);
    case Metric::SSIM:
      return per_channel(
          [](const Planes& t) { return ssim(t.vis, t.fused) + ssim(t.ir, t.fused); });
    case Metric::Qcb:
      return per_channel([](const Planes& t) { return qcb(t.vis, t.ir, t.fused); });
    case Metric::Qcv:
      return per_channel([](const Planes& t) { return qcv(t.vis, t.ir, t.fused); });
  }
  throw std::invalid_argument("unknown metric");
}

MetricValues vifb_metrics(const cv::Mat& visible, const cv::Mat& infrared, const cv::Mat& fused) {
  MetricValues out;
  for (Metric m : all_metrics()) out[m] = vifb_metric(m, visible, infrared, fused);
  return out;
}

cv::Mat jpeg_round_trip(const cv::Mat& image, int quality) {
  std::vector<uchar> bytes;
  if (!cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, quality})) {
    throw std::runtime_error("JPEG encoding failed");
  }
  return cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
}

}  // namespace thermovis::metrics
