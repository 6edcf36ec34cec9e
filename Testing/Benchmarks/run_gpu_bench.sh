#!/usr/bin/env bash
# GPU parity tests, sanitizer runs and benchmarks of the CUDA engine, for the device machine.
# Binaries and data are carried in .devcarry/ (bin/: nvTestGpuParity nvTestFilterTrainingGpu nvBenchGpu nvBench
# nvBenchRender nvTestGpuRender nvBenchOnline, optionally xz-compressed; data/: the data folders (stent/, walnut/, headsq/ with
# .nhdr + .raw, as in ../shared/data; timeseries/ from export_timeseries.py); ref/: the PyTorch reference scripts). Usage:
# run_gpu_bench.sh SECTION... with SECTION in
#   parity | archs | memcheck | racecheck | step | infer | infervariants | quality | seeds | cpucurves | torch |
#   online | deterministic | anydataset | probe | render | rendersweep | renderskip | rendertrain | renderlarge | renderimages | rendersanitize | renderparity
# Logs go to $OUT (or ./gpu-bench-out).
set -u
B=.devcarry/bin
D=.devcarry/data
O=${OUT:-gpu-bench-out}
mkdir -p "$O"
for f in $B/*.xz; do [ -e "$f" ] && xz -d -f "$f" && chmod +x "${f%.xz}"; done
# plugin builds link the engine as a shared library (libNeuralEngine.so, carried next to the binaries)
export LD_LIBRARY_PATH=$PWD/$B${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
STENT=$D/stent/stent_128x128x256_int16.nhdr
for s in "$@"; do
  case $s in
    parity)
      nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv | tee "$O/gpu.txt"
      $B/nvTestGpuParity 2>&1 | tee "$O/parity.log"
      # the Neural Compress filter's training loop (VTK-free part of Filters/) on the CUDA engine
      $B/nvTestFilterTrainingGpu 2>&1 | tee "$O/filter_training.log"
      # the two-pass training path on every test shape (auto picks it for tables > 16 MiB only)
      for t in gradients_match_cpu training_curve_matches_cpu host_sampled_equals_gpu_resident queued_steps_equal_single_steps; do
        $B/nvTestGpuParity $t --two-pass=1; done 2>&1 | tee "$O/parity_twopass.log"
      # the WMMA training kernel (used for widths > 64 or shapes whose staging does not fit) on every test shape
      for t in gradients_match_cpu training_curve_matches_cpu; do
        $B/nvTestGpuParity $t --wmma; done 2>&1 | tee "$O/parity_wmma.log" ;;
    archs)
      # Every GPU from Turing on, on this one. (1) Every kernel limited to the shared memory per block of an
      # sm_86/89/120 (99 KiB) and of an sm_75 (64 KiB): the suites against the CPU engine, and the step / inference
      # cost of the tilings chosen there. (2) The Turing code itself: binaries in .devcarry/bin75 carry compute_75
      # PTX only, which the driver compiles for this GPU (two m16n8k8 MMAs per m16n8k16, scalar gradient
      # reductions), run at 64 KiB.
      nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv | tee "$O/gpu.txt"
      for l in 101376 65536; do echo "== shared memory limit $l bytes"
        $B/nvTestGpuParity --smem-limit=$l; $B/nvTestGpuRender --smem-limit=$l; done 2>&1 | tee "$O/arch_limits.log"
      for l in 0 101376 65536; do for t in 14 19; do $B/nvBench --smem-limit=$l step cuda 65536 $t 4096 200; done
        $B/nvBenchGpu --smem-limit=$l infer 2097152 19 4096; $B/nvBenchGpu --smem-limit=$l decode 512 19 4096
        done 2>&1 | sed 's/^/limit /' | tee "$O/arch_limits_bench.log"
      if [ -d .devcarry/bin75 ]; then
        for f in .devcarry/bin75/*.xz; do [ -e "$f" ] && xz -d -f "$f" && chmod +x "${f%.xz}"; done
        ( time .devcarry/bin75/nvTestGpuParity --smem-limit=65536 ) 2>&1 | tee "$O/arch_turing_code.log"
        ( time .devcarry/bin75/nvTestGpuRender --smem-limit=65536 ) 2>&1 | tee -a "$O/arch_turing_code.log"
        for t in 14 19; do .devcarry/bin75/nvBench --smem-limit=65536 step cuda 65536 $t 4096 200; done 2>&1 | tee -a "$O/arch_turing_code.log"
      fi ;;
    memcheck)
      compute-sanitizer --tool memcheck --leak-check full $B/nvTestGpuParity gradients_match_cpu 2>&1 | tail -25 | tee "$O/memcheck.log"
      compute-sanitizer --tool memcheck $B/nvTestGpuParity host_sampled_equals_gpu_resident 2>&1 | tail -6 | tee -a "$O/memcheck.log"
      compute-sanitizer --tool memcheck $B/nvTestGpuParity decode_equals_batched_inference 2>&1 | tail -6 | tee -a "$O/memcheck.log"
      compute-sanitizer --tool memcheck $B/nvTestGpuParity binned_inference_equals_unbinned 2>&1 | tail -6 | tee -a "$O/memcheck.log"
      compute-sanitizer --tool memcheck $B/nvTestGpuParity queued_steps_equal_single_steps 2>&1 | tail -6 | tee -a "$O/memcheck.log"
      # two-pass training (level-major encode/scatter) is chosen for large tables only: force it on the test shapes
      compute-sanitizer --tool memcheck $B/nvTestGpuParity gradients_match_cpu --two-pass=1 2>&1 | tail -6 | tee -a "$O/memcheck.log" ;;
    racecheck)
      compute-sanitizer --tool racecheck $B/nvTestGpuParity gradients_match_cpu 2>&1 | tail -25 | tee "$O/racecheck.log"
      compute-sanitizer --tool racecheck $B/nvTestGpuParity inference_matches_cpu 2>&1 | tail -6 | tee -a "$O/racecheck.log"
      compute-sanitizer --tool racecheck $B/nvTestGpuParity binned_inference_equals_unbinned 2>&1 | tail -6 | tee -a "$O/racecheck.log"
      compute-sanitizer --tool racecheck $B/nvTestGpuParity gradients_match_cpu --two-pass=1 2>&1 | tail -6 | tee -a "$O/racecheck.log"
      compute-sanitizer --tool racecheck $B/nvTestGpuParity gradients_match_cpu --wmma 2>&1 | tail -6 | tee -a "$O/racecheck.log" ;;
    step)
      for b in 16384 32768 65536 131072 262144 524288 1048576; do $B/nvBench step cuda $b 19 4096 200; done 2>&1 | tee "$O/step_batch.log"
      for t in 14 16 18 19 20 22; do $B/nvBench step cuda 65536 $t 4096 200; done 2>&1 | tee "$O/step_table.log"
      for p in 0 1; do for t in 16 18 19; do $B/nvBench --two-pass=$p step cuda 65536 $t 4096 200; done; done 2>&1 | sed 's/^/forced /' | tee "$O/step_twopass.log"
      $B/nvBench --wmma step cuda 65536 19 4096 200 2>&1 | sed 's/^/wmma /' | tee -a "$O/step_twopass.log" ;;
    infer)
      for n in 2097152 8388608; do $B/nvBenchGpu infer $n 19 4096; done 2>&1 | tee "$O/infer.log"
      $B/nvBenchGpu decode 512 19 4096 2>&1 | tee -a "$O/infer.log"
      # --fwd-mode: 0 fused encode+MLP everywhere, 2 two passes for decoding too (default 1: two passes for points)
      for m in 0 2; do $B/nvBenchGpu --fwd-mode=$m infer 2097152 19 4096; $B/nvBenchGpu --fwd-mode=$m decode 512 19 4096; done 2>&1 | sed 's/^/mode /' | tee -a "$O/infer.log" ;;
    infervariants)
      # Inference design choices (pass 4): Morton binning of the points (--bin-bits, 0 = off, -1 = auto),
      # levels per thread in the level-major encode (--lpt 1/2/4, default 4), encoding scratch (--scratch-mb, 128).
      for n in 2097152 8388608; do for bits in 0 5 6; do for lpt in 1 2 4; do echo "n=$n bits=$bits lpt=$lpt"
        $B/nvBenchGpu --bin-bits=$bits --lpt=$lpt infer $n 19 4096; done; done; done 2>&1 | tee "$O/infer_variants.log"
      for c in 64 256; do echo "chunk=$c"; $B/nvBenchGpu --scratch-mb=$c infer 2097152 19 4096; done 2>&1 | tee -a "$O/infer_variants.log"
      for n in 65536 262144; do for bits in 0 -1; do echo "n=$n bits=$bits"
        $B/nvBenchGpu --bin-bits=$bits infer $n 19 4096; done; done 2>&1 | tee -a "$O/infer_variants.log" ;;
    seeds)
      # GPU curves over six seeds (the accuracy bar compares means: single runs spread +-0.5 dB at 500 steps)
      for sd in 1 2 3 4 5 6; do for v in stent_128x128x256_int16 walnut_128x96x114_uint16; do
        $B/nvBench curve cuda $D/${v%%_*}/$v.nhdr 14 500,1000,2000,4000 65536 $sd; done; done 2>&1 | tee "$O/seeds.log" ;;
    quality)
      # time to quality: wall from trainer creation (upload included), steps queued back to back between marks
      for r in 1 2 3; do
        $B/nvBenchGpu ttq $D/stent/stent_128x128x256_int16.nhdr 14 500,1000,1500,2000,2250,2500,3000,4000
        $B/nvBenchGpu ttq $D/walnut/walnut_128x96x114_uint16.nhdr 14 500,1000,2000,4000
      done 2>&1 | tee "$O/quality.log" ;;
    cpucurves)
      # The CPU engine's curves (the accuracy reference), 16 threads of the device machine.
      for v in stent_128x128x256_int16 walnut_128x96x114_uint16; do
        $B/nvBench curve cpu $D/${v%%_*}/$v.nhdr 14 500,1000,2000,4000
      done > "$O/cpu_curves.log" 2>&1 ;;
    render)
      # every path x shading mode on the anchor's setup (stent trained to the reference accuracy), 1280x720
      $B/nvBenchRender cuda $STENT 14 2250 1280 720 decode,stream,inshader rm,grad,shadow,pt,nee 20 2>&1 | tee "$O/render_720.log"
      $B/nvBenchRender cuda $STENT 14 2250 1920 1080 decode,inshader rm 20 2>&1 | tee "$O/render_1080.log" ;;
    rendersweep)
      $B/nvBenchRender cuda $STENT 14 2250 1280 720 sweep 10 2>&1 | tee "$O/render_sweep.log" ;;
    renderskip)
      $B/nvBenchRender cuda $STENT 14 2250 1280 720 skip 10 2>&1 | tee "$O/render_skip.log" ;;
    online)
      # the online filter's training run: background training with renders, pause / stop, warm starts, restores
      $B/nvTestFilterTrainingGpu 2>&1 | tee "$O/filter_training.log"
      $B/nvBenchOnline cuda live $STENT 14 2 1280 720 2>&1 | tee "$O/online_live.log"
      $B/nvBenchOnline cuda live $STENT 19 2 1920 1080 2>&1 | tee -a "$O/online_live.log"
      $B/nvBenchOnline cuda warm $D/timeseries/flow 10 10 14 1000 2>&1 | tee "$O/online_warm_flow.log"
      $B/nvBenchOnline cuda warm $D/timeseries/cth 0 9 16 1000 2>&1 | tee "$O/online_warm_cth.log"
      $B/nvBenchOnline cuda restore $STENT 16 1000 1280 720 2>&1 | tee "$O/online_restore.log"
      $B/nvBenchOnline cuda restore $STENT@2 19 1000 1280 720 2>&1 | tee -a "$O/online_restore.log" ;;
    deterministic)
      # Deterministic training (fixed-point gradient sums): bitwise repeatable on every kernel path, gradients
      # against the CPU, sanitizers, step time and accuracy against the default float atomics.
      nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv | tee "$O/gpu.txt"
      for f in "" --two-pass=1 --wmma; do echo "== kernels: ${f:-default}"
        $B/nvTestGpuParity deterministic_training_is_bitwise_repeatable $f
        $B/nvTestGpuParity gradients_match_cpu $f; done 2>&1 | tee "$O/det_parity.log"
      $B/nvTestFilterTrainingGpu deterministic_run_on_gpu_is_bitwise_repeatable 2>&1 | tee "$O/det_filter.log"
      for t in memcheck racecheck; do
        compute-sanitizer --tool $t $B/nvTestGpuParity gradients_match_cpu 2>&1 | tail -4; done 2>&1 | tee "$O/det_sanitize.log"
      for d in "" --deterministic; do for t in 14 19; do for b in 65536 262144; do
        $B/nvBench $d step cuda $b $t 4096 200; done; done; done 2>&1 | tee "$O/det_step.log"
      for d in "" --deterministic --deterministic; do
        $B/nvBench $d curve cuda $STENT 19 1000,4000 65536 1; done 2>&1 | tee "$O/det_curve.log" ;;
    anydataset)
      # Datasets that are not images, resampled onto the filter's automatic image (anydataset_bench.py exports them
      # to data/anydataset with their own samples): PSNR on the image and at the source's points / cells after
      # 1000 / 4000 GPU-resident steps, and the step rate next to stent's (an image) at the same table size.
      nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee "$O/gpu.txt"
      for n in disk_out_ref mug_t10 enzo_amr cth_amr; do for t in 14 19; do
        $B/nvBench --points=$D/anydataset/$n curve cuda $D/anydataset/$n.nhdr $t 1000,4000 65536 1; done; done 2>&1 | tee "$O/anydataset_curves.log"
      for t in 14 19; do $B/nvBench curve cuda $STENT $t 1000,4000 65536 1; done 2>&1 | tee -a "$O/anydataset_curves.log" ;;
    probe)
      # Sampling Probe's bank (anydataset_bench.py exports <name>.bank.f32: 2^20 points probed inside the source's
      # cells) trained GPU-resident, next to training from the resampled image: PSNR on the image and at the
      # source's own samples after 1000 / 4000 steps, and the step rate of each.
      nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee "$O/gpu.txt"
      for n in disk_out_ref mug_t10; do for t in 14 19; do
        $B/nvBench --points=$D/anydataset/$n curve cuda $D/anydataset/$n.nhdr $t 1000,4000 65536 1
        $B/nvBench --points=$D/anydataset/$n --bank=$D/anydataset/$n curve cuda $D/anydataset/$n.nhdr $t 1000,4000 65536 1
      done; done 2>&1 | tee "$O/probe_curves.log" ;;
    rendertrain)
      $B/nvBenchRender cuda $STENT 14 2250 1920 1080 train 2 2>&1 | tee "$O/render_train.log" ;;
    renderlarge)
      # a second, larger dataset: stent resampled to 255 x 255 x 511 (8x the voxels; the data folder has no larger
      # regular volume), a 2^19 table (the paper's size), every path x mode
      $B/nvBenchRender cuda $STENT@2 19 2000 1280 720 decode,stream,inshader rm,grad,shadow,pt,nee 10 2>&1 | tee "$O/render_large.log" ;;
    renderparity)
      $B/nvTestGpuRender --data $D 2>&1 | tee "$O/render_parity.log" ;;
    renderimages)
      mkdir -p /tmp/img
      $B/nvBenchRender cuda $STENT 14 2250 320 240 decode,stream,inshader rm,grad,shadow,pt,nee 2 /tmp/img > "$O/render_images.log" 2>&1
      (cd /tmp/img && tar czf "$O/render_images.tgz" *.ppm) ;;
    rendersanitize)
      H=$D/headsq/headsq_64x64x93_int16.nhdr
      compute-sanitizer --tool memcheck $B/nvBenchRender cuda $H 12 50 48 32 decode,stream,inshader rm,grad,shadow,pt,nee 1 2>&1 | tail -25 | tee "$O/render_memcheck.log"
      compute-sanitizer --tool racecheck $B/nvBenchRender cuda $H 12 50 48 32 inshader rm,grad 1 2>&1 | tail -8 | tee "$O/render_racecheck.log"
      # Sample Streaming with many batches per wavefront (K = 1024: 1170 rays per batch)
      compute-sanitizer --tool memcheck $B/nvBenchRender cuda $H 12 50 200 150 stream grad,rm,nee 1 - 1024 2>&1 | tail -8 | tee -a "$O/render_memcheck.log"
      compute-sanitizer --tool memcheck $B/nvTestGpuRender gpu_depth_buffer_and_inside_camera 2>&1 | tail -4 | tee -a "$O/render_memcheck.log" ;;
    torch)
      (cd .devcarry/ref && PYTHONUNBUFFERED=1 timeout 300 python3 quality_torch.py bench_torch.py 2000 14 ../data/stent/stent_128x128x256_int16.nhdr) 2>&1 | tail -15 | tee "$O/torch.log" ;;
  esac
done
