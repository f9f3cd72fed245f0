#!/usr/bin/env bash
# Sets up rootful podman for keyfleet's images and the container test (tests/container/):
#  1. installs podman, runc, netavark, aardvark-dns, iptables, debootstrap and podman-compose
#     (scripts/install_deps.sh --for containers; needs root);
#  2. writes containers.conf and storage.conf into a folder of their own, $KEYFLEET_CONTAINERS_DIR
#     (default /var/lib/keyfleet-containers), never into /etc/containers or ~/.config: runtime runc
#     (crun fails here: "cgroups in hybrid mode not supported") and default ulimits no higher than
#     this machine's hard limits (podman's defaults fail with "setrlimit RLIMIT_NOFILE: Operation
#     not permitted"); images, containers and build caches are stored in that folder too;
#  3. makes the Debian 12 base image (debootstrap --variant=minbase bookworm from the apt mirror
#     this machine uses, podman import as debian:12) unless it is already there: no image registry
#     is needed, `FROM debian:12` builds without a pull;
#  4. proves it: runs a container on podman's default network and one on a network of its own
#     (netavark and its iptables firewall rules, as compose's networks use them); any failure ends
#     the script with an error naming the command and podman's message.
# Idempotent: a second run only checks (and runs the two containers again, a few seconds). Then
# use podman with the printed environment, e.g.
#   eval "$(scripts/container_setup.sh --print-env)"; podman images
# Options: --print-env (print the two exports only, set nothing up), --no-install (skip apt-get),
#   --check-host (set nothing up: exit 0 where this machine can run containers, else print why
#   not, "no root" or what the kernel refuses (namespaces, cgroups), and exit 77).
set -euo pipefail

dir=${KEYFLEET_CONTAINERS_DIR:-/var/lib/keyfleet-containers}
base_image=debian:12
print_env_only=0
install=1
check_host_only=0
for arg in "$@"; do
  case "$arg" in
    --print-env) print_env_only=1 ;;
    --no-install) install=0 ;;
    --check-host) check_host_only=1 ;;
    -h|--help) sed -n '2,23p' "$0"; exit 0 ;;
    *) echo "container_setup: error: unknown option '$arg' (see --help)" >&2; exit 2 ;;
  esac
done

if [ "$print_env_only" = 1 ]; then
  echo "export CONTAINERS_CONF='$dir/containers.conf' CONTAINERS_STORAGE_CONF='$dir/storage.conf'"
  exit 0
fi

say() { echo "container_setup: $*"; }
die() { echo "container_setup: error: $*" >&2; exit 1; }

# Whether this machine can run rootful containers at all, narrowly: root, and a kernel that lets
# root make the namespaces and a cgroup a container needs. Prints why not and returns 77.
check_host() {
  if [ "$(id -u)" -ne 0 ]; then
    echo "container_setup: this machine cannot run keyfleet's containers: no root (rootful podman)"
    return 77
  fi
  local out
  if ! out=$(unshare --mount --uts --ipc --net --pid --fork true 2>&1); then
    echo "container_setup: this machine cannot run containers: the kernel refuses namespaces" \
         "(unshare --mount --uts --ipc --net --pid: ${out:-failed})"
    return 77
  fi
  local parent=""
  if [ -f /sys/fs/cgroup/cgroup.controllers ]; then
    parent=/sys/fs/cgroup                       # cgroup v2
  else
    for controller in pids memory cpu; do       # cgroup v1 (or hybrid)
      [ -d "/sys/fs/cgroup/$controller" ] && { parent=/sys/fs/cgroup/$controller; break; }
    done
  fi
  if [ -z "$parent" ]; then
    echo "container_setup: this machine cannot run containers: no cgroup hierarchy under /sys/fs/cgroup"
    return 77
  fi
  local probe="$parent/keyfleet-check.$$"
  if ! out=$(mkdir "$probe" 2>&1); then
    echo "container_setup: this machine cannot run containers: the kernel refuses cgroups" \
         "(mkdir $probe: $out)"
    return 77
  fi
  rmdir "$probe"
  return 0
}

if [ "$check_host_only" = 1 ]; then
  check_host && { echo "container_setup: this machine can run containers (root, namespaces, cgroups)"; exit 0; }
  exit 77
fi

[ "$(id -u)" -eq 0 ] || die "rootful podman and apt-get need root: run this script as root (sudo $0)"
check_host >&2 || die "see above"

# 1. Packages: scripts/install_deps.sh --for containers names them and why.
root=$(cd "$(dirname "$0")/.." && pwd)
if [ "$install" = 1 ]; then
  "$root/scripts/install_deps.sh" --for containers
else
  missing=()
  while read -r pkg; do
    dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
  done < <("$root/scripts/install_deps.sh" --list --for containers)
  [ ${#missing[@]} -eq 0 ] || die "missing Debian packages: ${missing[*]} (run without --no-install)"
fi
command -v iptables >/dev/null 2>&1 ||
  die "iptables is not on PATH: netavark (podman's network stack) runs it for every container network"

# 2. Configuration of its own. The run-time state goes to a tmpfs folder named after $dir, so
# that two such folders on one machine never share it and a reboot clears it.
mkdir -p "$dir/storage" "$dir/tmp"
run_state=/run/keyfleet-containers-$(printf '%s' "$dir" | sha1sum | cut -c1-10)
nofile=$(ulimit -Hn)
[ "$nofile" = unlimited ] && nofile=1048576
nproc_limit=$(cat /proc/sys/kernel/pid_max)
hard_nproc=$(ulimit -Hu)
if [ "$hard_nproc" != unlimited ] && [ "$hard_nproc" -lt "$nproc_limit" ]; then
  nproc_limit=$hard_nproc
fi
cgroup_manager=cgroupfs
[ -d /run/systemd/system ] && cgroup_manager=systemd

conf_tmp=$(mktemp "$dir/containers.conf.XXXXXX")
cat > "$conf_tmp" <<EOF
# Written by keyfleet's scripts/container_setup.sh; used through CONTAINERS_CONF.
[containers]
# No higher than this machine's hard limits (ulimit -Hn, kernel.pid_max / ulimit -Hu).
default_ulimits = ["nofile=$nofile:$nofile", "nproc=$nproc_limit:$nproc_limit"]

[engine]
runtime = "runc"
cgroup_manager = "$cgroup_manager"
events_logger = "file"
tmp_dir = "$run_state/libpod"
# Builds' temporary files and their cache mounts (the build stage's ccache) stay in this folder.
image_copy_tmp_dir = "$dir/tmp"

[network]
network_backend = "netavark"
EOF
mv "$conf_tmp" "$dir/containers.conf"

storage_tmp=$(mktemp "$dir/storage.conf.XXXXXX")
cat > "$storage_tmp" <<EOF
# Written by keyfleet's scripts/container_setup.sh; used through CONTAINERS_STORAGE_CONF.
[storage]
driver = "overlay"
graphroot = "$dir/storage"
runroot = "$run_state/storage"
EOF
mv "$storage_tmp" "$dir/storage.conf"
export CONTAINERS_CONF="$dir/containers.conf" CONTAINERS_STORAGE_CONF="$dir/storage.conf"
say "configuration in $dir (containers.conf, storage.conf)"

podman info >/dev/null 2>"$dir/podman-info.err" ||
  die "podman does not start with this configuration: $(tail -n 3 "$dir/podman-info.err")"

# 3. The base image.
if podman image exists "$base_image"; then
  say "base image $base_image present"
else
  mirror=${KEYFLEET_DEBIAN_MIRROR:-}
  if [ -z "$mirror" ]; then
    # The first Debian URI apt uses here (deb822 .sources files, then one-line .list files).
    mirror=$(grep -hsE '^URIs:' /etc/apt/sources.list.d/*.sources | awk '{print $2}' |
             grep -v security | head -n 1 || true)
  fi
  if [ -z "$mirror" ]; then
    mirror=$(grep -hsE '^deb ' /etc/apt/sources.list /etc/apt/sources.list.d/*.list |
             grep -v security | awk '{for (i = 2; i <= NF; i++) if ($i ~ /^[a-z]+:\/\//) {print $i; exit}}' |
             head -n 1 || true)
  fi
  [ -n "$mirror" ] || die "no Debian mirror found in /etc/apt/sources.list*; set KEYFLEET_DEBIAN_MIRROR"
  rootfs=$(mktemp -d "$dir/rootfs.XXXXXX")
  trap 'rm -rf "$rootfs"' EXIT
  say "debootstrap --variant=minbase bookworm from $mirror (about 30 s)"
  debootstrap --variant=minbase bookworm "$rootfs" "$mirror" > "$dir/debootstrap.log" 2>&1 ||
    die "debootstrap failed, see $dir/debootstrap.log: $(tail -n 3 "$dir/debootstrap.log")"
  # The image's apt sees the same suites as this machine: updates and security as well.
  printf '%s\n' "deb $mirror bookworm main" "deb $mirror bookworm-updates main" \
    "deb ${KEYFLEET_DEBIAN_SECURITY_MIRROR:-${mirror%/debian}/debian-security} bookworm-security main" \
    > "$rootfs/etc/apt/sources.list"
  rm -rf "$rootfs"/var/cache/apt/archives/*.deb "$rootfs"/var/lib/apt/lists/*
  tar -C "$rootfs" -c . | podman import --change 'CMD ["/bin/bash"]' - "$base_image" >/dev/null ||
    die "podman import of the debootstrapped tree failed"
  say "base image $base_image made"
fi

# 4. Proof: a container runs, on podman's default network and on a network of its own (netavark
# sets up a bridge and its iptables rules for each; compose's fleet network is such a one).
smoke() {
  local what=$1; shift
  local log="$dir/smoke.log"
  if ! timeout 120 "$@" > "$log" 2>&1; then
    die "$what failed: '$*' exited non-zero: $(tail -n 5 "$log")
(podman's network stack needs netavark, aardvark-dns and iptables with the kernel's iptables/nf_tables support)"
  fi
}
smoke "running a container" podman run --rm --pull=never "$base_image" true
check_net=keyfleet-setup-check
podman network rm -f "$check_net" >/dev/null 2>&1 || true
smoke "creating a container network" podman network create "$check_net"
smoke "running a container on a network of its own" \
  podman run --rm --pull=never --network "$check_net" "$base_image" \
  sh -c 'grep -q . /sys/class/net/eth0/address'
podman network rm -f "$check_net" >/dev/null 2>&1 || true
say "a container ran, on the default network and on $check_net (netavark)"
say "ready: eval \"\$(KEYFLEET_CONTAINERS_DIR=$dir $0 --print-env)\" before calling podman or podman-compose"
