// NeuralVolume engine: error type and checks with file:line.
#pragma once

#include <stdexcept>
#include <string>

namespace nv
{

/// Every failure inside the engine is reported as nv::Error; the VTK layer turns it into vtkErrorMacro.
class Error : public std::runtime_error
{
public:
  explicit Error(const std::string& what)
    : std::runtime_error(what)
  {
  }
};

[[noreturn]] void throwError(const char* file, int line, const std::string& message);

} // namespace nv

#define NV_THROW(msg) ::nv::throwError(__FILE__, __LINE__, (msg))
#define NV_CHECK(cond, msg)                                                                        \
  do                                                                                               \
  {                                                                                                \
    if (!(cond))                                                                                   \
    {                                                                                              \
      ::nv::throwError(__FILE__, __LINE__, std::string("check failed (" #cond "): ") + (msg));     \
    }                                                                                              \
  } while (0)
