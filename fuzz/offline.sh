# Sourced by campaign.sh and ci.sh: sets `offline`, a command prefix that runs a fuzz target
# in a network namespace of its own, with only that namespace's loopback up (wire_client talks
# to its server over a local socket), where the system permits one (`unshare -n`, as root);
# empty otherwise. A cfg names hosts and CfgFile::load looks them up as Player does: on this
# machine's DNS each made-up name cost ~30 ms of waiting (the cfg target ran 1,170 inputs/s on
# an idle core); offline the lookup fails at once, and fuzzed names never leave the machine.
offline=()
if unshare -n sh -c 'ip link set lo up' 2>/dev/null; then
    offline=(unshare -n sh -c 'ip link set lo up && exec "$@"' sh)
fi
