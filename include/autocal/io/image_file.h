// Images read from files and compressed messages, with their faults named: a folder, a missing or
// unreadable file, data no decoder knows, and a JPEG or PNG cut short (OpenCV decodes those with a
// warning and grey rows, which would pass as an image with no board or tag in it).
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "autocal/io/atomic_file.h"

namespace autocal {

/// Empty when `bytes` are not a JPEG or PNG, or one that ends as it should; otherwise why not,
/// e.g. "truncated JPEG (no end-of-image marker)".
std::string truncatedImage(const std::vector<unsigned char>& bytes);

/// Decodes `bytes` (cv::imdecode with `flags`); throws InputError "<source>: ..." when they are
/// empty, cut short, or do not decode.
cv::Mat decodeImage(const std::vector<unsigned char>& bytes, int flags, const std::string& source);

/// Reads and decodes the image file `path`; throws InputError naming a folder, a missing or
/// unreadable file, a truncated or undecodable image.
cv::Mat readImageFile(const std::string& path, int flags);

/// Encodes `image` as PNG and writes it with writeFileAtomically; throws IoError naming the path
/// when it cannot be encoded or written.
void writePngAtomically(const std::string& path, const cv::Mat& image,
                        const AtomicWriteOptions& options = AtomicWriteOptions());

}  // namespace autocal
