// NeuralVolume engine, out-of-core training: text helpers of the volume file headers (VolumeFileText.h).
#include "VolumeFileText.h"

#include "Core/Error.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <sys/stat.h>

namespace nv
{
namespace volumefiletext
{

int64_t fileSize(const std::string& path, const std::string& where)
{
  struct stat status;
  if (::stat(path.c_str(), &status) != 0)
    NV_THROW(where + "cannot open '" + path + "': " + std::strerror(errno));
  if (!S_ISREG(status.st_mode))
    NV_THROW(where + "'" + path + "' is not a regular file");
  return static_cast<int64_t>(status.st_size);
}

std::string readHead(const std::string& path, int64_t maxBytes, const std::string& where)
{
  const int64_t size = std::min(fileSize(path, where), maxBytes);
  std::ifstream in(path, std::ios::binary);
  if (!in)
    NV_THROW(where + "cannot read '" + path + "'");
  std::string text(static_cast<size_t>(size), '\0');
  in.read(&text[0], size);
  text.resize(static_cast<size_t>(in.gcount()));
  return text;
}

std::string lower(std::string text)
{
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return std::tolower(c); });
  return text;
}

std::string trim(const std::string& text)
{
  const size_t first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos)
    return std::string();
  const size_t last = text.find_last_not_of(" \t\r\n");
  return text.substr(first, last - first + 1);
}

std::string clip(const std::string& text)
{
  std::string shown;
  for (char c : text.substr(0, 60))
    shown += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
  return text.size() > 60 ? shown + "..." : shown;
}

int64_t integer(const std::string& text, const std::string& where)
{
  const std::string t = trim(text);
  char* end = nullptr;
  errno = 0;
  const long long value = std::strtoll(t.c_str(), &end, 10);
  if (t.empty() || errno != 0 || *end != '\0')
    NV_THROW(where + "'" + clip(text) + "' is not an integer");
  return static_cast<int64_t>(value);
}

std::vector<double> numbers(const std::string& text, char separator, const std::string& where)
{
  std::string spaced = text;
  if (separator != ' ')
    std::replace(spaced.begin(), spaced.end(), separator, ' ');
  std::istringstream in(spaced);
  std::vector<double> values;
  std::string word;
  while (in >> word)
  {
    char* end = nullptr;
    const double value = std::strtod(word.c_str(), &end);
    if (*end != '\0')
      NV_THROW(where + "'" + clip(word) + "' is not a number");
    values.push_back(value);
  }
  return values;
}

void integers3(const std::string& text, int64_t out[3], const std::string& where)
{
  std::istringstream in(text);
  std::string word;
  int count = 0;
  while (in >> word)
  {
    if (count == 3)
      NV_THROW(where + "more than 3 sizes ('" + clip(text) + "'): a volume of one component per sample has 3");
    out[count++] = integer(word, where);
  }
  if (count != 3)
    NV_THROW(where + "'" + clip(text) + "' does not give 3 sizes");
}

void reals3(const std::string& text, double out[3], char separator, const std::string& where)
{
  const std::vector<double> values = numbers(text, separator, where);
  if (values.size() != 3)
    NV_THROW(where + "'" + clip(text) + "' does not give 3 numbers");
  std::copy(values.begin(), values.end(), out);
}

std::string fileExtension(const std::string& path)
{
  const size_t slash = path.find_last_of('/');
  const size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash))
    return std::string();
  return path.substr(dot);
}

std::string fileStem(const std::string& path)
{
  const size_t slash = path.find_last_of('/');
  std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  const size_t dot = name.find_last_of('.');
  return dot == std::string::npos ? name : name.substr(0, dot);
}

std::string besideHeader(const std::string& header, const std::string& name)
{
  if (!name.empty() && name[0] == '/')
    return name;
  const size_t slash = header.find_last_of('/');
  return slash == std::string::npos ? name : header.substr(0, slash + 1) + name;
}

} // namespace volumefiletext
} // namespace nv
