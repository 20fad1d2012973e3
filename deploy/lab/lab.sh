#!/usr/bin/env bash
# A lab of several hosts on one machine: one network namespace per host, each with its own
# loopback and an eth0 veth link to a switch (a Linux bridge in a namespace of its own), all on
# one IPv4 subnet with a multicast route, so DDS discovery (SPDP multicast) and unicast work as
# between real machines. Everything lives inside the lab's namespaces: the machine's own
# interfaces, routes and sysctls are never touched. Needs root (or CAP_NET_ADMIN + CAP_SYS_ADMIN).
#
#   lab.sh up [--hosts a,b,c] [--mtu 1500] [--no-multicast]
#                                            make the lab (fails if it exists); --no-multicast:
#                                            no multicast route (discovery needs a server)
#   lab.sh down                              stop the processes in it and remove it
#   lab.sh exec HOST CMD...                  run CMD on HOST (replaces this shell: same pid)
#   lab.sh ip HOST                           HOST's address
#   lab.sh link HOST down|up                 cut / restore HOST's cable (switch side, so HOST
#                                            keeps its addresses and routes, as with a real cut)
#   lab.sh shape HOST [--rate 1gbit] [--delay 1ms] [--loss 0.1%]
#                                            limit HOST's egress (tc: tbf for a rate alone,
#                                            netem for delay and loss)
#   lab.sh unshape HOST
#   lab.sh status                            hosts, addresses, link states
#   lab.sh gc                                remove labs left by test processes that died
#
# The lab's name (--name NAME or $THERMOVIS_LAB, default "tvlab") prefixes every namespace
# (NAME-HOST, NAME-sw), so labs made by parallel tests do not collide. Addresses:
# 10.77.0.(10 + index) in the order of --hosts (--subnet 10.77.0 to change); inside each
# namespace they are private to the lab, so two labs may use the same subnet.
set -euo pipefail

name="${THERMOVIS_LAB:-tvlab}"
hosts="a,b,c"
subnet="10.77.0"
mtu=1500
multicast=1
rate="" delay="" loss=""

die() {
  echo "lab.sh: $*" >&2
  exit 2
}

usage() {
  sed -n '2,/^set -euo/p' "$0" | sed -e '$d' -e 's/^# \{0,1\}//'
  exit "${1:-0}"
}

# Global options may come before or after the command.
args=()
while (($#)); do
  case "$1" in
    --name) name="${2:?--name needs a value}"; shift 2 ;;
    --hosts) hosts="${2:?--hosts needs a value}"; shift 2 ;;
    --subnet) subnet="${2:?--subnet needs a value}"; shift 2 ;;
    --mtu) mtu="${2:?--mtu needs a value}"; shift 2 ;;
    --no-multicast) multicast=0; shift ;;
    --rate) rate="${2:?--rate needs a value}"; shift 2 ;;
    --delay) delay="${2:?--delay needs a value}"; shift 2 ;;
    --loss) loss="${2:?--loss needs a value}"; shift 2 ;;
    -h | --help) usage 0 ;;
    exec)
      # Everything after "exec HOST" belongs to the command.
      args+=("$@")
      break
      ;;
    *) args+=("$1"); shift ;;
  esac
done
((${#args[@]})) || usage 2
command="${args[0]}"

[[ "$name" =~ ^[A-Za-z0-9][A-Za-z0-9_.-]{0,40}$ ]] || die "bad lab name '$name'"
[[ "$mtu" =~ ^[0-9]+$ ]] && ((mtu >= 1280 && mtu <= 65535)) || die "bad --mtu '$mtu'"
[[ "$subnet" =~ ^[0-9]{1,3}\.[0-9]{1,3}\.[0-9]{1,3}$ ]] || die "bad --subnet '$subnet'"
command -v ip >/dev/null || die "'ip' (iproute2) not found"

switch_ns="$name-sw"
host_ns() { echo "$name-$1"; }

# The lab's hosts: the namespaces named NAME-* other than the switch.
lab_hosts() {
  ip netns list 2>/dev/null | awk '{print $1}' | while read -r ns; do
    [[ "$ns" == "$name-"* && "$ns" != "$switch_ns" ]] && echo "${ns#"$name-"}"
  done | sort
}

require_host() {
  [[ -n "${1:-}" ]] || die "missing HOST"
  ip netns list | awk '{print $1}' | grep -qx "$(host_ns "$1")" ||
    die "no host '$1' in lab '$name' (hosts: $(lab_hosts | paste -sd, -))"
}

host_ip() {
  ip -n "$(host_ns "$1")" -4 -o addr show dev eth0 | awk '{print $4}' | cut -d/ -f1
}

lab_up() {
  ip netns list | awk '{print $1}' | grep -qx "$switch_ns" &&
    die "lab '$name' exists already (lab.sh --name $name down)"
  IFS=, read -r -a list <<<"$hosts"
  ((${#list[@]} >= 1 && ${#list[@]} <= 200)) || die "--hosts: 1 to 200 names"
  local h
  for h in "${list[@]}"; do
    # The switch-side port is named p-HOST: interface names have at most 15 characters.
    [[ "$h" =~ ^[a-z0-9][a-z0-9_]{0,12}$ && "$h" != sw ]] ||
      die "bad host name '$h' (a-z, 0-9, _; at most 13 characters; not 'sw')"
  done
  # A failure half-way removes what was made.
  trap 'lab_down >/dev/null 2>&1 || true' ERR
  ip netns add "$switch_ns"
  ip -n "$switch_ns" link set lo up
  # No IGMP snooping: with no querier on the lab's switch, snooping could stop multicast
  # (SPDP) towards hosts whose membership reports it missed; a lab switch floods instead.
  ip -n "$switch_ns" link add br0 type bridge mcast_snooping 0
  ip -n "$switch_ns" link set br0 mtu "$mtu" up
  local i=0 ns
  for h in "${list[@]}"; do
    ns="$(host_ns "$h")"
    ip netns add "$ns"
    ip -n "$ns" link set lo up
    ip -n "$switch_ns" link add "p-$h" mtu "$mtu" type veth peer name eth0 netns "$ns"
    ip -n "$switch_ns" link set "p-$h" master br0 up
    ip -n "$ns" link set eth0 mtu "$mtu" up
    ip -n "$ns" addr add "$subnet.$((10 + i))/24" dev eth0
    # SPDP discovery goes to 239.255.0.1: multicast leaves through the lab link.
    if ((multicast)); then ip -n "$ns" route add 224.0.0.0/4 dev eth0; fi
    i=$((i + 1))
  done
  trap - ERR
  lab_status
}

# Stops the processes still running in the lab's namespaces (TERM, then KILL after 5 s), then
# removes the namespaces (which removes their links).
lab_down() {
  local namespaces=() ns pids=()
  while read -r ns; do
    [[ "$ns" == "$name-"* ]] && namespaces+=("$ns")
  done < <(ip netns list 2>/dev/null | awk '{print $1}')
  ((${#namespaces[@]})) || return 0
  for ns in "${namespaces[@]}"; do
    mapfile -t -O "${#pids[@]}" pids < <(ip netns pids "$ns" 2>/dev/null || true)
  done
  if ((${#pids[@]})); then
    kill -TERM "${pids[@]}" 2>/dev/null || true
    for _ in $(seq 50); do
      local alive=()
      for p in "${pids[@]}"; do kill -0 "$p" 2>/dev/null && alive+=("$p"); done
      ((${#alive[@]})) || break
      sleep 0.1
    done
    for p in "${pids[@]}"; do kill -KILL "$p" 2>/dev/null || true; done
  fi
  for ns in "${namespaces[@]}"; do ip netns del "$ns" 2>/dev/null || true; done
  echo "lab '$name' removed (${#namespaces[@]} namespaces)"
}

lab_status() {
  local h
  echo "lab '$name' (switch namespace $switch_ns)"
  for h in $(lab_hosts); do
    printf '  %-14s namespace %-24s %-15s link %s\n' "$h" "$(host_ns "$h")" "$(host_ip "$h")" \
      "$(ip -n "$switch_ns" -o link show "p-$h" 2>/dev/null | grep -qw 'state UP' && echo up ||
        echo down)"
  done
}

case "$command" in
  up) lab_up ;;
  down) lab_down ;;
  status) lab_status ;;
  ip)
    require_host "${args[1]:-}"
    host_ip "${args[1]}"
    ;;
  exec)
    host="${args[1]:-}"
    require_host "$host"
    ((${#args[@]} > 2)) || die "exec: missing command"
    exec ip netns exec "$(host_ns "$host")" "${args[@]:2}"
    ;;
  link)
    host="${args[1]:-}"
    state="${args[2]:-}"
    require_host "$host"
    [[ "$state" == up || "$state" == down ]] || die "link: state must be up or down"
    ip -n "$switch_ns" link set "p-$host" "$state"
    ;;
  shape)
    host="${args[1]:-}"
    require_host "$host"
    [[ -n "$rate$delay$loss" ]] || die "shape: give --rate, --delay and/or --loss"
    if [[ -z "$delay$loss" ]]; then
      # Rate only: a token bucket (tbf), present in kernels without sch_netem. Queue of up to
      # 100 ms at that rate: a real switch port buffers, it does not drop a burst at once.
      ip netns exec "$(host_ns "$host")" tc qdisc replace dev eth0 root tbf rate "$rate" \
        burst 1mb latency 100ms ||
        die "shape: tc tbf failed (rate like 1gbit, 100mbit)"
    else
      netem=()
      [[ -n "$delay" ]] && netem+=(delay "$delay")
      [[ -n "$loss" ]] && netem+=(loss "$loss")
      [[ -n "$rate" ]] && netem+=(rate "$rate")
      ip netns exec "$(host_ns "$host")" tc qdisc replace dev eth0 root netem "${netem[@]}" \
        limit 100000 || die "shape: tc netem failed (is the kernel module sch_netem there?)"
    fi
    ;;
  unshape)
    host="${args[1]:-}"
    require_host "$host"
    ip netns exec "$(host_ns "$host")" tc qdisc del dev eth0 root 2>/dev/null || true
    ;;
  gc)
    # Labs of tests are named tvl<pid>-<n>: remove those whose process is gone.
    for ns in $(ip netns list 2>/dev/null | awk '{print $1}'); do
      if [[ "$ns" =~ ^(tvl([0-9]+)-[0-9]+)-sw$ ]] && ! kill -0 "${BASH_REMATCH[2]}" 2>/dev/null; then
        "$0" --name "${BASH_REMATCH[1]}" down
      fi
    done
    ;;
  *) die "unknown command '$command' (up, down, exec, ip, link, shape, unshape, status, gc)" ;;
esac
