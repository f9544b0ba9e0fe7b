#include "autocal/io/image_file.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>

#include "autocal/errors.h"

namespace autocal {

std::string truncatedImage(const std::vector<unsigned char>& bytes) {
  const auto starts = [&](std::initializer_list<unsigned char> magic) {
    return bytes.size() >= magic.size() && std::equal(magic.begin(), magic.end(), bytes.begin());
  };
  if (starts({0xFF, 0xD8})) {
    // The end-of-image marker FF D9 closes a JPEG; writers may pad a few bytes after it.
    const size_t from = bytes.size() > 64 ? bytes.size() - 64 : 0;
    for (size_t i = bytes.size(); i-- > from + 1;)
      if (bytes[i - 1] == 0xFF && bytes[i] == 0xD9) return {};
    return "truncated JPEG (no end-of-image marker)";
  }
  if (starts({0x89, 'P', 'N', 'G'})) {
    static const std::string kIend = "IEND";
    const size_t from = bytes.size() > 64 ? bytes.size() - 64 : 0;
    if (std::search(bytes.begin() + from, bytes.end(), kIend.begin(), kIend.end()) != bytes.end())
      return {};
    return "truncated PNG (no IEND chunk)";
  }
  return {};
}

cv::Mat decodeImage(const std::vector<unsigned char>& bytes, int flags, const std::string& source) {
  if (bytes.empty()) throw InputError(source + ": empty image data");
  const std::string cut = truncatedImage(bytes);
  if (!cut.empty()) throw InputError(source + ": corrupt image: " + cut);
  cv::Mat image = cv::imdecode(bytes, flags);
  if (image.empty())
    throw InputError(source + ": corrupt image: no decoder reads it (not a JPEG, PNG or BMP?)");
  return image;
}

cv::Mat readImageFile(const std::string& path, int flags) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(path, ec))
    throw InputError(path + ": is a folder, not an image (give a pattern, e.g. '" + path +
                     "/*.jpg')");
  if (!fs::exists(path, ec)) throw InputError(path + ": no such file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot read the file (permissions?)");
  const std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)),
                                         std::istreambuf_iterator<char>());
  return decodeImage(bytes, flags, path);
}

void writePngAtomically(const std::string& path, const cv::Mat& image,
                        const AtomicWriteOptions& options) {
  std::vector<uchar> png;
  if (image.empty() || !cv::imencode(".png", image, png))
    throw IoError(path + ": cannot encode the PNG");
  writeFileAtomically(path, std::string(png.begin(), png.end()), options);
}

}  // namespace autocal
