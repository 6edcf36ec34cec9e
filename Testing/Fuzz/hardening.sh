#!/usr/bin/env bash
# The instrumented engine-only build and its runs (used by the ctests of Testing/Fuzz/CMakeLists.txt):
#   hardening.sh build    SOURCE BUILD [DATA]  configure + build with Clang: ASan + UBSan + libFuzzer coverage
#                                              (NV_FUZZ=ON), engine only, CPU only; the fuzz target, the corpus
#                                              generator and every engine test
#   hardening.sh sanitize SOURCE BUILD         the engine tests (ctest -L engine); any sanitizer report, crash or
#                                              timeout fails
#   hardening.sh fuzz     SOURCE BUILD SECONDS nvFuzzModel for SECONDS from the valid seed corpus; a crash, a leak,
#                                              an input slower than 10 s or above 2.5 GB fails (the input is kept
#                                              in BUILD/fuzz-artifacts and printed)
#   hardening.sh fuzzvdb  SOURCE BUILD SECONDS nvFuzzVdbFile (the OpenVDB header check) likewise, from valid .vdb
#                                              layouts (nvFuzzVdbCorpus); inputs kept in BUILD/fuzz-vdb-artifacts
set -euo pipefail
mode=$1 src=$2 dir=$3
export ASAN_OPTIONS=halt_on_error=1:abort_on_error=1:detect_leaks=1:check_initialization_order=1:strict_init_order=1
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
# run_fuzzer PREFIX SEED-GENERATOR TARGET DICTIONARY MAX-LEN SECONDS: the target from the generator's valid seeds;
# new inputs go to BUILD/fuzz-PREFIXcorpus (started empty, so that a run depends on the sources only), failing inputs
# to BUILD/fuzz-PREFIXartifacts.
run_fuzzer() {
  local prefix=$1 generator=$2 target=$3 dict=$4 maxlen=$5 seconds=$6
  local seeds="$dir/fuzz-${prefix}seeds" corpus="$dir/fuzz-${prefix}corpus" artifacts="$dir/fuzz-${prefix}artifacts"
  rm -rf "$seeds" "$corpus"
  mkdir -p "$seeds" "$corpus" "$artifacts"
  "$dir/Testing/Fuzz/$generator" "$seeds"
  "$dir/Testing/Fuzz/$target" "$corpus" "$seeds" -dict="$src/Testing/Fuzz/$dict" -seed=1 -max_total_time="$seconds" \
    -timeout=10 -rss_limit_mb=2560 -malloc_limit_mb=1024 -max_len="$maxlen" -print_final_stats=1 \
    -artifact_prefix="$artifacts/"
}

case "$mode" in
  build)
    data=${4:-$src/../shared/data}
    cxx=$(command -v clang++ || true)
    cc=$(command -v clang || true)
    if [ -z "$cxx" ] || [ -z "$cc" ]; then
      echo "hardening: clang++ not found (Testing/setup.sh installs clang and libclang-rt-14-dev)" >&2
      exit 1
    fi
    if [ ! -f "$dir/build.ninja" ]; then
      cmake -S "$src" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release -DNV_ENGINE_ONLY=ON -DNV_ENABLE_CUDA=OFF \
        -DNV_FUZZ=ON -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_C_COMPILER="$cc" -DNV_DATA_DIR="$data" >"$dir.configure.log" \
        || { cat "$dir.configure.log"; exit 1; }
    fi
    cmake --build "$dir" -j "$(nproc)" --target nvFuzzModel nvFuzzCorpus nvFuzzVdbFile nvFuzzVdbCorpus \
      nvEngineTests
    ;;
  sanitize)
    # Every report (ASan, UBSan, LeakSanitizer) is written to BUILD/sanitizer-reports and fails the run, as does a
    # test that crashes or times out. A check that fails without a report is listed, not fatal: instrumented code
    # rounds differently (path-traced baselines) and runs 5-20x slower (time-budget checks); the uninstrumented
    # build's ctest -L engine checks both.
    reports="$dir/sanitizer-reports"
    rm -rf "$reports"
    mkdir -p "$reports"
    export ASAN_OPTIONS="$ASAN_OPTIONS:log_path=$reports/asan"
    export UBSAN_OPTIONS="$UBSAN_OPTIONS:log_path=$reports/ubsan"
    cd "$dir"
    status=0
    ctest -L engine --output-on-failure --timeout 900 >"$dir/sanitize.log" 2>&1 || status=$?
    cat "$dir/sanitize.log"
    if [ -n "$(ls -A "$reports")" ]; then
      echo "hardening: sanitizer reports:" >&2
      cat "$reports"/* >&2
      exit 1
    fi
    if grep -E '\*\*\*(Timeout|Exception)|Not Run|Could not find|No tests were found' "$dir/sanitize.log" >&2; then
      echo "hardening: an engine test crashed, timed out or did not run under the sanitizers" >&2
      exit 1
    fi
    if [ "$status" -ne 0 ]; then
      echo "hardening: no sanitizer report; the checks above failed under instrumentation only (not fatal here)"
    fi
    ;;
  fuzz)
    run_fuzzer "" nvFuzzCorpus nvFuzzModel model.dict 8192 "${4:-60}"
    ;;
  fuzzvdb)
    run_fuzzer vdb- nvFuzzVdbCorpus nvFuzzVdbFile vdb.dict 4096 "${4:-30}"
    ;;
  *)
    echo "usage: hardening.sh build|sanitize|fuzz|fuzzvdb SOURCE BUILD [DATA|SECONDS]" >&2
    exit 2
    ;;
esac
