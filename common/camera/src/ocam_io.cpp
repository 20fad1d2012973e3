#include "thermovis/camera/ocam_io.hpp"

#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace thermovis::camera {
namespace {

// The data lines of the file (non-empty, not starting with '#'), in order.
std::vector<std::string> data_lines(std::istream& in) {
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) {
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    lines.push_back(line);
  }
  return lines;
}

std::vector<double> numbers(const std::string& line, const std::string& source,
                            const std::string& block) {
  std::istringstream in(line);
  std::vector<double> values;
  std::string token;
  while (in >> token) {
    try {
      size_t used = 0;
      values.push_back(std::stod(token, &used));
      if (used != token.size()) throw std::invalid_argument(token);
    } catch (const std::exception&) {
      throw std::runtime_error(source + ": " + block + ": '" + token + "' is not a number");
    }
  }
  return values;
}

std::vector<double> counted(const std::string& line, const std::string& source,
                            const std::string& block) {
  auto values = numbers(line, source, block);
  if (values.empty()) throw std::runtime_error(source + ": " + block + ": empty line");
  // The count is compared as a double: converting a negative, huge or non-finite value to an
  // integer first would be undefined.
  if (!(values.front() == static_cast<double>(values.size() - 1))) {
    throw std::runtime_error(source + ": " + block + ": count " + std::to_string(values.front()) +
                             " does not match the " + std::to_string(values.size() - 1) +
                             " coefficients given");
  }
  if (values.size() < 2) throw std::runtime_error(source + ": " + block + ": no coefficients");
  values.erase(values.begin());
  return values;
}

// A side of the image: a whole number of pixels in 1..kMaxImageSide.
int image_side(double value, const std::string& source, const char* name) {
  if (!(value >= 1 && value <= kMaxImageSide) || value != std::floor(value)) {
    throw std::runtime_error(source + ": image size: " + name + " " + std::to_string(value) +
                             " is not a whole number of pixels in 1.." +
                             std::to_string(kMaxImageSide));
  }
  return static_cast<int>(value);
}

}  // namespace

TaylorIntrinsics parse_ocam_calib_results(std::istream& in, const std::string& source_name) {
  const auto lines = data_lines(in);
  if (lines.size() < 5) {
    throw std::runtime_error(source_name +
                             ": expected 5 blocks (polynomial, inverse polynomial, "
                             "centre, affine, image size), found " +
                             std::to_string(lines.size()));
  }
  TaylorIntrinsics intr;
  intr.pol = counted(lines[0], source_name, "polynomial");
  intr.invpol = counted(lines[1], source_name, "inverse polynomial");
  const auto centre = numbers(lines[2], source_name, "centre");
  const auto affine = numbers(lines[3], source_name, "affine");
  const auto size = numbers(lines[4], source_name, "image size");
  if (centre.size() != 2) throw std::runtime_error(source_name + ": centre: expected 'row column'");
  if (affine.size() != 3) throw std::runtime_error(source_name + ": affine: expected 'c d e'");
  if (size.size() != 2)
    throw std::runtime_error(source_name + ": image size: expected 'height width'");
  intr.xc = centre[0];
  intr.yc = centre[1];
  intr.c = affine[0];
  intr.d = affine[1];
  intr.e = affine[2];
  intr.height = image_side(size[0], source_name, "height");
  intr.width = image_side(size[1], source_name, "width");
  try {
    TaylorCamera check(intr);  // validates every value
  } catch (const std::exception& e) {
    throw std::runtime_error(source_name + ": " + e.what());
  }
  return intr;
}

TaylorIntrinsics read_ocam_calib_results(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path.string() + ": cannot open");
  return parse_ocam_calib_results(in, path.string());
}

void write_ocam_calib_results(const TaylorIntrinsics& intr, std::ostream& out) {
  TaylorIntrinsics full = intr;
  if (full.invpol.empty()) full = TaylorCamera(intr).intrinsics();
  out << std::setprecision(10);
  out << "#polynomial coefficients for the DIRECT mapping function (ocam_model.ss in MATLAB). "
         "These are used by cam2world\n\n"
      << full.pol.size();
  for (double a : full.pol) out << ' ' << a;
  out << "\n\n#polynomial coefficients for the inverse mapping function (ocam_model.invpol in "
         "MATLAB). These are used by world2cam\n\n"
      << full.invpol.size();
  for (double a : full.invpol) out << ' ' << a;
  out << "\n\n#center: \"row\" and \"column\", starting from 0 (C convention)\n\n"
      << full.xc << ' ' << full.yc << "\n\n#affine parameters \"c\", \"d\", \"e\"\n\n"
      << full.c << ' ' << full.d << ' ' << full.e << "\n\n#image size: \"height\" and \"width\"\n\n"
      << full.height << ' ' << full.width << "\n\n";
}

void write_ocam_calib_results(const TaylorIntrinsics& intrinsics,
                              const std::filesystem::path& path) {
  std::ostringstream text;
  write_ocam_calib_results(intrinsics, text);
  std::ofstream out(path);
  if (!out || !(out << text.str())) throw std::runtime_error(path.string() + ": cannot write");
}

}  // namespace thermovis::camera
