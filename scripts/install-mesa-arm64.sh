#!/usr/bin/env bash
# Mesa's mobile compilers without a phone: qemu-user-static (Debian's, for this machine) and an
# arm64 Debian user space holding Mesa's GL ES drivers with their drm-shim null devices
# (mesa-drm-shim, libgl1-mesa-dri and EGL from bookworm-backports, Mesa 25.0) and an arm64 Python
# that drives them (`pipeline.isa.gles`). The arm64 packages and their dependencies are resolved by
# apt in a private state folder and unpacked (dpkg -x) into ROOT, so nothing of this machine's own
# packages changes. Usage: install-mesa-arm64.sh [ROOT] (default /opt/pipeline/mesa-arm64). Needs
# root and apt-get; exits non-zero, leaving no partial ROOT, on failure.
set -euo pipefail
ROOT=${1:-${PIPELINE_MESA_ARM64:-/opt/pipeline/mesa-arm64}}
PACKAGES="mesa-drm-shim libgl1-mesa-dri libegl-mesa0 libegl1 libgles2 python3.11-minimal libpython3.11-stdlib"
KEYRING=/usr/share/keyrings/debian-archive-keyring.gpg
MIRROR=${PIPELINE_DEBIAN_MIRROR:-http://deb.debian.org/debian}

if ! command -v qemu-aarch64-static >/dev/null; then
    DEBIAN_FRONTEND=noninteractive apt-get install -y -q qemu-user-static >/dev/null 2>&1 \
        || (apt-get update -q >/dev/null 2>&1 && DEBIAN_FRONTEND=noninteractive apt-get install -y -q qemu-user-static >/dev/null 2>&1)
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/state/lists/partial" "$work/cache/archives/partial" "$work/root"
touch "$work/state/status"
cat > "$work/sources.list" <<LIST
deb [arch=arm64 signed-by=$KEYRING] $MIRROR bookworm main
deb [arch=arm64 signed-by=$KEYRING] $MIRROR bookworm-backports main
LIST
apt=(-o "Dir::State=$work/state" -o "Dir::State::status=$work/state/status" -o "Dir::Cache=$work/cache"
     -o "Dir::Etc::SourceList=$work/sources.list" -o "Dir::Etc::SourceParts=$work/none"
     -o "Dir::Etc::Preferences=$work/none" -o "Dir::Etc::PreferencesParts=$work/none"
     -o APT::Architecture=arm64 -o APT::Architectures::=arm64 -o Debug::NoLocking=1 -o APT::Sandbox::User=root -q)
mkdir -p "$work/none"
apt-get "${apt[@]}" update >/dev/null
apt-get "${apt[@]}" install -y --download-only -t bookworm-backports $PACKAGES >/dev/null
for deb in "$work"/cache/archives/*.deb; do
    dpkg -x "$deb" "$work/root"
done
rm -rf "$ROOT.partial"
mkdir -p "$(dirname "$ROOT")"
mv "$work/root" "$ROOT.partial"
rm -rf "$ROOT"
mv "$ROOT.partial" "$ROOT"
echo "Mesa's arm64 compilers in $ROOT: $(ls "$ROOT"/usr/lib/aarch64-linux-gnu/libgallium-*.so | sed 's/.*libgallium-//; s/\.so$//')"
