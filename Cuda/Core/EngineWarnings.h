// NeuralVolume engine: warnings of engine code that has no caller to hand them to.
//
// A thread pool that could create fewer threads than asked goes on with the threads it got; its constructor cannot
// return a message, so it posts one here and the VTK side (the filter's RequestData, the mapper's render) reports
// what was posted as a warning:
//   nv::postWarning("could create only 3 of 1024 threads ...");
//   for (const std::string& w : nv::takeWarnings()) vtkWarningMacro(<< w);
// Each distinct message is posted once per process (a pool made again with the same shortfall says nothing new).
#pragma once

#include <string>
#include <vector>

namespace nv
{

/// Keeps `message` for takeWarnings() unless the same text was posted before in this process.
void postWarning(const std::string& message);

/// The warnings posted since the last call, oldest first (thread-safe).
std::vector<std::string> takeWarnings();

} // namespace nv
