# Instrumented builds of the engine (included by the top-level CMakeLists.txt before the engine is added).
#   NV_SANITIZE=ON  AddressSanitizer + UndefinedBehaviorSanitizer on everything built (engine, tests), every report
#                   fatal (-fno-sanitize-recover=all). GCC or Clang; meant for engine-only CPU builds:
#                   cmake -DNV_ENGINE_ONLY=ON -DNV_ENABLE_CUDA=OFF -DNV_SANITIZE=ON
#   NV_FUZZ=ON      NV_SANITIZE plus the fuzz targets nvFuzzModel and nvFuzzVdbFile and their corpus generators
#                   nvFuzzCorpus and nvFuzzVdbCorpus (Testing/Fuzz);
#                   libFuzzer's coverage instruments the reader's sources only (Testing/Fuzz/CMakeLists.txt), so
#                   that the engine tests of the same build run at sanitizer speed. Clang only
#                   (-DCMAKE_CXX_COMPILER=clang++).
# The main build stays uninstrumented: its ctests sanitize.* and fuzz.* configure such a build of their own
# (Testing/Fuzz/CMakeLists.txt).
option(NV_SANITIZE "Build with AddressSanitizer and UndefinedBehaviorSanitizer (engine-only CPU builds)" OFF)
option(NV_FUZZ "Build the libFuzzer target of the model reader (Clang; implies NV_SANITIZE)" OFF)

if(NV_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "NV_FUZZ needs Clang (libFuzzer): configure with -DCMAKE_CXX_COMPILER=clang++")
  endif()
  set(NV_SANITIZE ON)
endif()

if(NV_SANITIZE)
  if(NV_HAVE_CUDA)
    message(FATAL_ERROR "NV_SANITIZE instruments the CPU engine only: configure with -DNV_ENABLE_CUDA=OFF")
  endif()
  set(nv_sanitizers "-fsanitize=address,undefined")
  add_compile_options($<$<COMPILE_LANGUAGE:CXX>:${nv_sanitizers}> $<$<COMPILE_LANGUAGE:CXX>:-fno-sanitize-recover=all>
    $<$<COMPILE_LANGUAGE:CXX>:-fno-omit-frame-pointer> $<$<COMPILE_LANGUAGE:CXX>:-g>)
  add_link_options(${nv_sanitizers})
  message(STATUS "NeuralVolume: AddressSanitizer + UndefinedBehaviorSanitizer build (fuzz target: ${NV_FUZZ})")
endif()
