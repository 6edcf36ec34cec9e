// Minimal test harness for the engine tests: CHECK macros that count failures; main runs registered cases.
#pragma once

#include <cmath>
#include <cstdio>
#include <exception>
#include <functional>
#include <string>
#include <vector>

namespace nvtest
{
struct Case
{
  const char* name;
  std::function<void()> fn;
};
inline std::vector<Case>& cases()
{
  static std::vector<Case> c;
  return c;
}
inline int& failures()
{
  static int f = 0;
  return f;
}
struct Register
{
  Register(const char* n, std::function<void()> f) { cases().push_back({ n, std::move(f) }); }
};
inline void fail(const char* file, int line, const std::string& msg)
{
  std::printf("  FAILED %s:%d: %s\n", file, line, msg.c_str());
  ++failures();
}
/// |a-b| <= abs + rel*|b|, NaN never passes.
inline bool near(double a, double b, double rel, double abs)
{
  return std::isfinite(a) && std::isfinite(b) && std::fabs(a - b) <= abs + rel * std::fabs(b);
}
/// Runs every registered case, or only the one named by argv[1]; 0 when all pass.
inline int runCases(int argc, char** argv)
{
  int ran = 0;
  for (auto& c : cases())
  {
    if (argc > 1 && std::string(argv[1]) != c.name)
      continue;
    const int before = failures();
    try
    {
      c.fn();
    }
    catch (const std::exception& e)
    {
      fail(__FILE__, __LINE__, std::string("exception: ") + e.what());
    }
    std::printf("%s %s\n", failures() == before ? "PASS" : "FAIL", c.name);
    std::fflush(stdout);
    ++ran;
  }
  if (ran == 0)
  {
    std::printf("no test matched\n");
    return 1;
  }
  return failures() == 0 ? 0 : 1;
}
} // namespace nvtest

#define NV_TEST(name)                                                                              \
  static void name();                                                                              \
  static nvtest::Register reg_##name(#name, name);                                                 \
  static void name()

#define EXPECT_TRUE(c)                                                                             \
  do                                                                                               \
  {                                                                                                \
    if (!(c))                                                                                      \
      nvtest::fail(__FILE__, __LINE__, #c);                                                        \
  } while (0)

#define EXPECT_NEAR_REL(a, b, rel, abs)                                                            \
  do                                                                                               \
  {                                                                                                \
    const double va_ = (a), vb_ = (b);                                                             \
    if (!nvtest::near(va_, vb_, (rel), (abs)))                                                     \
      nvtest::fail(__FILE__, __LINE__,                                                             \
        std::string(#a " = ") + std::to_string(va_) + " vs " #b " = " + std::to_string(vb_));      \
  } while (0)

#define EXPECT_THROW_MSG(stmt, substr)                                                             \
  do                                                                                               \
  {                                                                                                \
    bool thrown_ = false;                                                                          \
    try                                                                                            \
    {                                                                                              \
      stmt;                                                                                        \
    }                                                                                              \
    catch (const std::exception& e_)                                                               \
    {                                                                                              \
      thrown_ = true;                                                                              \
      if (std::string(e_.what()).find(substr) == std::string::npos)                                \
        nvtest::fail(__FILE__, __LINE__, std::string("message '") + e_.what() + "' lacks '" + (substr) + "'"); \
    }                                                                                              \
    if (!thrown_)                                                                                  \
      nvtest::fail(__FILE__, __LINE__, "no exception from " #stmt);                                \
  } while (0)

#define NV_TEST_MAIN()                                                                             \
  int main(int argc, char** argv)                                                                  \
  {                                                                                                \
    return nvtest::runCases(argc, argv);                                                           \
  }
