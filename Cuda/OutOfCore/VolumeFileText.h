// NeuralVolume engine, out-of-core training: text helpers of the volume file headers (VolumeFileHeaders.cpp,
// VolumeFileBov.cpp, VolumeFileVti.cpp). Every reader of a number names what it read in its error.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace nv
{
struct VolumeFileLayout;

namespace volumefiletext
{
/// A header is read from at most this many bytes of its file.
constexpr int64_t kMaxHeaderBytes = int64_t(1) << 20;

/// Size of `path` in bytes; `where` prefixes the error when it cannot be read.
int64_t fileSize(const std::string& path, const std::string& where);
/// The first min(file size, maxBytes) bytes of `path`.
std::string readHead(const std::string& path, int64_t maxBytes, const std::string& where);
std::string lower(std::string text);
std::string trim(const std::string& text);
/// At most 60 characters of `text` for a message (a garbage header must not flood the output window).
std::string clip(const std::string& text);
int64_t integer(const std::string& text, const std::string& where);
/// Numbers separated by `separator` (or white space when it is ' ').
std::vector<double> numbers(const std::string& text, char separator, const std::string& where);
void integers3(const std::string& text, int64_t out[3], const std::string& where);
void reals3(const std::string& text, double out[3], char separator, const std::string& where);
std::string fileExtension(const std::string& path);
std::string fileStem(const std::string& path);
/// `name` as a path: absolute as it is, else relative to the folder of `header`.
std::string besideHeader(const std::string& header, const std::string& name);
} // namespace volumefiletext

// The formats (VolumeFileHeaders.cpp: NRRD; VolumeFileBov.cpp; VolumeFileVti.cpp). Each fills the layout from its
// header; readVolumeFileLayout then checks it (finishLayout).
VolumeFileLayout readNrrdLayout(const std::string& path, bool detached);
VolumeFileLayout readBovLayout(const std::string& path);
VolumeFileLayout readVtiLayout(const std::string& path, const std::string& arrayName);
/// The checks every format shares: sizes, spacing, origin, and the data file against the bytes the header promises.
/// samplesEndTheFile: the samples are the data file's last bytes (NRRD "byte skip: -1"): dataOffset is set here.
void finishLayout(VolumeFileLayout& layout, bool samplesEndTheFile);

} // namespace nv
