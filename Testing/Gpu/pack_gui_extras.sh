#!/usr/bin/env bash
# What the ParaView GUI needs on the device machine beyond ../shared/tools/pv-runtime's pack: Qt's X11 platform
# plugins (loaded at run time, so pack.sh's ldd misses them) and xdotool for the drags of gui_frames_script.py, with
# every library they load (libc, libstdc++, libgcc and the GPU driver's left to the host).
# usage (here): pack_gui_extras.sh OUT.tar.xz [PVRT_PARTS_DIR] ; with the runtime's parts, the libraries they hold
# already are left out. There, paraview_gpu_env.sh unpacks .devcarry/gui-extras.tar.xz.
set -euo pipefail
out=$(readlink -f "$1")
qt=/usr/lib/x86_64-linux-gnu/qt5/plugins
work=$(mktemp -d)
mkdir -p "$work/gui/bin" "$work/gui/lib" "$work/gui/qt5/plugins"
cp -a /usr/bin/xdotool "$work/gui/bin/"
for d in platforms xcbglintegrations platformthemes imageformats iconengines; do
  [ -d "$qt/$d" ] && cp -a "$qt/$d" "$work/gui/qt5/plugins/"
done
packed=$work/packed
touch "$packed"
if [ -n "${2:-}" ]; then cat "$2"/pvrt.tar.xz.part-* | xz -dc | tar -t | sed 's|.*/||' | sort -u > "$packed"; fi
hostlibs='/(libc\.so|libm\.so|libstdc\+\+|libgcc_s|ld-linux|libpthread|libdl\.so|librt\.so|libresolv|libcuda\.so|libnvidia)'
find "$work/gui" -type f \( -name '*.so*' -o -name xdotool \) -print0 | xargs -0 -n1 ldd 2>/dev/null |
  awk '/=>/ && $3 ~ /^\// {print $3}' | sort -u | grep -vE "$hostlibs" | while read -r l; do
    r=$(readlink -f "$l")
    if grep -qxF "$(basename "$r")" "$packed" && grep -qxF "$(basename "$l")" "$packed"; then continue; fi
    cp -a "$r" "$work/gui/lib/"
    so=$(objdump -p "$r" | awk '/SONAME/ {print $2}')
    if [ -n "$so" ] && [ "$so" != "$(basename "$r")" ]; then ln -sf "$(basename "$r")" "$work/gui/lib/$so"; fi
  done
tar -cf - -C "$work" gui | xz -T2 -6 > "$out"
rm -rf "$work"
ls -la "$out"
