# The architectures faithd ships for, and how each flight binary is built and run:
# sourced by debian/build-deb, debian/check-deb and .ci/run.
#
# Both binaries link against glibc 2.31 (Debian 11, Ubuntu 20.04, JetPack 5, Pi OS
# Bullseye) through cargo-zigbuild, whose zig carries every glibc's symbol versions,
# so they run on the companions builders fly and on everything newer. rustup cannot
# fetch arm64's standard library here; Debian's rustc-web ships one
# (libstd-rust-web-dev:arm64), so the arm64 build uses Debian's rustc. An arm64
# binary runs on this machine under `qemu-aarch64 -L /`: the arm64 C library that
# libstd-rust-web-dev:arm64 brings in, with its own loader (with -L
# /usr/aarch64-linux-gnu the cross package's older loader meets that newer libc, and
# a program that starts a thread hangs).

# The newest glibc the binaries may ask for.
GLIBC_BASELINE=2.31
# Pinned so that a build is the same build next year.
ZIGLANG_VERSION=0.17.1
CARGO_ZIGBUILD_VERSION=0.24.1

# Rust's target triple for a Debian architecture.
faithd_triple() {
    case $1 in
        amd64) echo x86_64-unknown-linux-gnu ;;
        arm64) echo aarch64-unknown-linux-gnu ;;
        *) echo "unknown architecture '$1': faithd ships for amd64 and arm64" >&2; return 2 ;;
    esac
}

# What runs a binary of that architecture here (nothing for the native one).
faithd_runner() {
    case $1 in
        amd64) echo "" ;;
        arm64) echo "qemu-aarch64 -L /" ;;
    esac
}

# Where the flight binary of that architecture is built.
faithd_binary() {
    echo "${CARGO_TARGET_DIR:-target}/$(faithd_triple "$1")/release/faithd"
}

# Installs what building for `$1` needs, each only when missing: zig (PyPI's ziglang),
# cargo-zigbuild and cargo-deb (crates.io), and for arm64 Debian's rustc with arm64's
# standard library, arm64's strip (cargo-deb strips the binary) and qemu-user. Logs go to standard error.
faithd_install_build_tools() {
    local arch=$1
    python3 -c 'import ziglang' 2>/dev/null ||
        python3 -m pip install --quiet --disable-pip-version-check "ziglang==$ZIGLANG_VERSION" >&2
    command -v cargo-zigbuild >/dev/null ||
        cargo install --quiet --locked "cargo-zigbuild@$CARGO_ZIGBUILD_VERSION" >&2
    command -v cargo-deb >/dev/null || cargo install --quiet --locked cargo-deb >&2
    if [[ $arch == arm64 ]] && ! { [[ -x /usr/bin/rustc ]] &&
        [[ -d /usr/lib/rustlib/aarch64-unknown-linux-gnu ]] && command -v qemu-aarch64 >/dev/null &&
        command -v aarch64-linux-gnu-strip >/dev/null; }; then
        if [[ $(id -u) != 0 ]]; then
            echo "building for arm64 needs Debian's rustc with arm64's standard library and qemu-user; as root:" >&2
            echo "  dpkg --add-architecture arm64 && apt-get update && apt-get install rustc-web libstd-rust-web-dev:arm64 binutils-aarch64-linux-gnu qemu-user" >&2
            return 1
        fi
        dpkg --add-architecture arm64
        apt-get update -qq >&2
        apt-get install -y -qq rustc-web libstd-rust-web-dev:arm64 binutils-aarch64-linux-gnu qemu-user >/dev/null
    fi
}

# Builds the flight binary (no simulation commands) for `$1`, linked for glibc
# $GLIBC_BASELINE, and prints its path.
faithd_build_flight() {
    local arch=$1 triple
    triple=$(faithd_triple "$arch")
    faithd_install_build_tools "$arch"
    if [[ $arch == arm64 ]]; then
        RUSTC=/usr/bin/rustc cargo zigbuild --release --no-default-features --locked \
            --target "$triple.$GLIBC_BASELINE" >&2
    else
        cargo zigbuild --release --no-default-features --locked --target "$triple.$GLIBC_BASELINE" >&2
    fi
    faithd_binary "$arch"
}

# Whether glibc version `$1` is no newer than the baseline.
faithd_within_baseline() {
    [[ $(printf '%s\n%s\n' "$1" "$GLIBC_BASELINE" | sort -V | tail -n 1) == "$GLIBC_BASELINE" ]]
}

# The newest GLIBC_x.y symbol version that the ELF file `$1` asks for.
faithd_newest_glibc() {
    readelf --version-info --wide "$1" | grep -o 'Name: GLIBC_[0-9.]*' | sed 's/Name: GLIBC_//' |
        sort -V | tail -n 1
}

# Points the daemon's tests at the arm64 flight binary under qemu-aarch64: exports
# FAITHD_UNDER_TEST and FAITHD_UNDER_TEST_CAER_MOCK (tests/testsuite/common/mod.rs),
# after building with zig, for arm64, the C mock of libcaer the camera tests open and
# tests/qemu/termios2.c, which gives the emulated binary the termios2 serial ioctls
# that qemu-user does not translate. Neither is shipped.
faithd_export_arm64_under_test() {
    local dir=${CARGO_TARGET_DIR:-target}/qemu-arm64 zig_cc=(python3 -m ziglang cc -target "aarch64-linux-gnu.$GLIBC_BASELINE")
    mkdir -p "$dir"
    "${zig_cc[@]}" -shared -fPIC -O2 -Wall -Wextra -Werror -o "$dir/libtermios2.so" tests/qemu/termios2.c
    "${zig_cc[@]}" -shared -fPIC -pthread -O2 -Wall -Wextra -Werror -o "$dir/libcaer_mock.so" libcaer-sys/mock/caer_mock.c
    FAITHD_UNDER_TEST="qemu-aarch64 -L / -E LD_PRELOAD=$(realpath "$dir/libtermios2.so") $(realpath "$(faithd_binary arm64)")"
    FAITHD_UNDER_TEST_CAER_MOCK=$(realpath "$dir/libcaer_mock.so")
    export FAITHD_UNDER_TEST FAITHD_UNDER_TEST_CAER_MOCK
}
