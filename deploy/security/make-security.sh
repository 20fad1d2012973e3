#!/usr/bin/env bash
# DDS Security material for thermovis (Fast DDS built-in plugins: PKI-DH authentication,
# Access-Permissions, AES-GCM-GMAC), made with openssl into one folder:
#
#   make-security.sh [--out DIR] [--days N] [--domains 0-232] [IDENTITY...]
#   make-security.sh [--out DIR] --revoke NAME|CERT.pem [--revoke ...]
#
# DIR: default $THERMOVIS_SECURITY_DIR, else ./thermovis-security.
#
#   ca.key.pem, ca.cert.pem        the CA (ECDSA P-256) that signs identities and documents
#   crl.pem                        the CA's certificate revocation list, valid --days: every
#                                  participant refuses a peer whose certificate is on it, and
#                                  does not start with such a certificate of its own
#   ca.cnf, revoked.txt, crl.txt   the CA's bookkeeping for crl.pem (openssl ca)
#   governance.xml / .p7s          the domain rules, signed (S/MIME) by the CA
#   NAME.key.pem, NAME.cert.pem    one identity per participant name (the services use their
#                                  executable name: thermovis-bridge, ...)
#   NAME.permissions.xml / .p7s    what NAME may publish and subscribe, signed by the CA
#
# Identities (default: every service, the supervisor, a "thermovis-consumer" that may read
# ranges, and "thermovis-ranges-only" that may publish ranges and nothing else):
#   thermovis-bridge thermovis-rectify-fuse thermovis-detect thermovis-match thermovis-range
#   thermovis-obstacles thermovis-supervisor thermovis-consumer thermovis-ranges-only
# An identity not in that list gets no permission at all (default DENY).
#
# Governance: no unauthenticated participant joins; read and write access control on every
# topic; the small topics (detections, matches, ranges, obstacles, timing, health) signed and
# encrypted;
# discovery signed. The frame topics are access-controlled but not encrypted: within one host
# they travel by data-sharing (a pointer into shared memory, which encryption cannot cover), and
# encrypting 12.5 MB per frame on another host costs more than the link (README).
#
# --revoke puts certificates on crl.pem (an identity's current NAME.cert.pem, or any certificate
# file this CA signed) and changes nothing else; copy crl.pem to the hosts and restart their
# services (a participant reads the list when it starts).
#
# The private keys are written 0600; keep the CA key off the vehicles. Re-running replaces the
# identities and documents but keeps an existing CA and its revocations (delete ca.*.pem to make
# a new one).
set -euo pipefail

out="${THERMOVIS_SECURITY_DIR:-thermovis-security}"
days=3650
domains="0-232"
identities=()
revoke=()
while (($#)); do
  case "$1" in
    --out) out="${2:?--out needs a folder}"; shift 2 ;;
    --days) days="${2:?--days needs a number}"; shift 2 ;;
    --domains) domains="${2:?--domains needs MIN-MAX}"; shift 2 ;;
    --revoke) revoke+=("${2:?--revoke needs an identity or a certificate file}"); shift 2 ;;
    -h | --help) sed -n '2,/^set -euo/p' "$0" | sed -e '$d' -e 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "make-security.sh: unknown option $1" >&2; exit 2 ;;
    *) identities+=("$1"); shift ;;
  esac
done
command -v openssl >/dev/null || { echo "make-security.sh: openssl not found" >&2; exit 2; }
[[ "$domains" =~ ^([0-9]+)-([0-9]+)$ ]] || { echo "make-security.sh: --domains MIN-MAX" >&2; exit 2; }
dmin="${BASH_REMATCH[1]}" dmax="${BASH_REMATCH[2]}"
((${#identities[@]})) || identities=(thermovis-bridge thermovis-rectify-fuse thermovis-detect
  thermovis-match thermovis-range thermovis-obstacles thermovis-supervisor thermovis-consumer
  thermovis-ranges-only)

# Certificate files named relative to the caller's folder, before changing to DIR.
revoke_files=()
for r in "${revoke[@]}"; do
  if [[ -f "$r" ]]; then
    revoke_files+=("$(cd "$(dirname "$r")" && pwd)/$(basename "$r")")
  else
    revoke_files+=("$r")
  fi
done

mkdir -p "$out"
cd "$out"
umask 077

# The CA's revocation list, signed again after every change: `openssl ca` keeps the revoked
# certificates in revoked.txt (its index) and the list's number in crl.txt.
ca_config() {
  cat >ca.cnf <<EOT
[ ca ]
default_ca = thermovis
[ thermovis ]
database = revoked.txt
crlnumber = crl.txt
default_md = sha256
default_crl_days = $days
unique_subject = no
EOT
  [[ -f revoked.txt ]] || : >revoked.txt
  [[ -f crl.txt ]] || echo 1000 >crl.txt
}
write_crl() {
  ca_config
  openssl ca -config ca.cnf -gencrl -cert ca.cert.pem -keyfile ca.key.pem -out crl.pem 2>/dev/null
  chmod 0644 crl.pem
}

if ((${#revoke_files[@]})); then
  [[ -f ca.key.pem && -f ca.cert.pem ]] || { echo "make-security.sh: no CA in $(pwd)" >&2; exit 2; }
  ca_config
  for r in "${revoke_files[@]}"; do
    cert="$r"
    [[ -f "$cert" ]] || cert="$r.cert.pem"
    [[ -f "$cert" ]] || { echo "make-security.sh: no certificate $r or $r.cert.pem" >&2; exit 2; }
    openssl verify -CAfile ca.cert.pem "$cert" >/dev/null 2>&1 ||
      { echo "make-security.sh: $cert is not signed by this CA" >&2; exit 2; }
    openssl ca -config ca.cnf -revoke "$cert" -cert ca.cert.pem -keyfile ca.key.pem 2>/dev/null
    echo "revoked $(openssl x509 -in "$cert" -noout -serial) ($(basename "$cert"))"
  done
  write_crl
  echo "DDS Security revocation list $(pwd)/crl.pem: $(grep -c '^R' revoked.txt) revoked"
  exit 0
fi

if [[ ! -f ca.key.pem || ! -f ca.cert.pem ]]; then
  rm -f revoked.txt* crl.txt* crl.pem  # a new CA has revoked nothing
  openssl ecparam -name prime256v1 -genkey -noout -out ca.key.pem
  openssl req -x509 -new -key ca.key.pem -sha256 -days "$days" -subj "/O=thermovis/CN=thermovis CA" \
    -out ca.cert.pem
fi

sign() {  # an XML document -> its S/MIME signature by the CA (what Fast DDS reads)
  openssl smime -sign -text -in "$1.xml" -out "$1.p7s" -signer ca.cert.pem -inkey ca.key.pem
}

# What each identity publishes and subscribes (DDS topic names; * as in fnmatch).
publishes() {
  case "$1" in
    thermovis-bridge) echo "thermovis/frames/* thermovis/health" ;;
    thermovis-rectify-fuse) echo "thermovis/rectified/* thermovis/fused thermovis/fused/packed thermovis/geometry thermovis/health" ;;
    thermovis-detect) echo "thermovis/detections thermovis/health" ;;
    thermovis-match) echo "thermovis/matches thermovis/health" ;;
    thermovis-range) echo "thermovis/ranges thermovis/timing thermovis/health" ;;
    thermovis-obstacles) echo "thermovis/obstacles thermovis/health" ;;
    thermovis-ranges-only) echo "thermovis/ranges" ;;
  esac
}
subscribes() {
  case "$1" in
    thermovis-rectify-fuse) echo "thermovis/frames/*" ;;
    thermovis-detect) echo "thermovis/geometry thermovis/rectified/* thermovis/fused thermovis/fused/packed" ;;
    thermovis-match) echo "thermovis/geometry thermovis/detections thermovis/rectified/* thermovis/fused thermovis/fused/packed" ;;
    thermovis-range) echo "thermovis/geometry thermovis/matches" ;;
    thermovis-obstacles) echo "thermovis/geometry thermovis/rectified/* thermovis/ranges" ;;
    thermovis-supervisor) echo "thermovis/health thermovis/timing thermovis/ranges" ;;
    thermovis-consumer) echo "thermovis/ranges thermovis/obstacles" ;;
  esac
}

topic_rule() {  # topic expression, protection kind of its data and metadata
  cat <<EOF
      <topic_rule>
        <topic_expression>$1</topic_expression>
        <enable_discovery_protection>false</enable_discovery_protection>
        <enable_liveliness_protection>false</enable_liveliness_protection>
        <enable_read_access_control>true</enable_read_access_control>
        <enable_write_access_control>true</enable_write_access_control>
        <metadata_protection_kind>$2</metadata_protection_kind>
        <data_protection_kind>$2</data_protection_kind>
      </topic_rule>
EOF
}

cat >governance.xml <<EOF
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-Security/20170801/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains><id_range><min>$dmin</min><max>$dmax</max></id_range></domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>SIGN</discovery_protection_kind>
      <liveliness_protection_kind>NONE</liveliness_protection_kind>
      <rtps_protection_kind>NONE</rtps_protection_kind>
      <topic_access_rules>
$(topic_rule 'thermovis/frames/*' NONE)
$(topic_rule 'thermovis/rectified/*' NONE)
$(topic_rule 'thermovis/fused' NONE)
$(topic_rule 'thermovis/fused/packed' NONE)
$(topic_rule '*' ENCRYPT)
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
EOF
sign governance

not_before="$(date -u +%Y-%m-%dT%H:%M:%S)"
not_after="$(date -u -d "+$days days" +%Y-%m-%dT%H:%M:%S)"
topics_xml() {
  local t
  for t in $1; do echo "                <topic>$t</topic>"; done
}
for id in "${identities[@]}"; do
  [[ "$id" =~ ^[A-Za-z0-9_.-]+$ ]] || { echo "make-security.sh: bad identity '$id'" >&2; exit 2; }
  openssl ecparam -name prime256v1 -genkey -noout -out "$id.key.pem"
  openssl req -new -key "$id.key.pem" -sha256 -subj "/O=thermovis/CN=$id" -out "$id.csr.pem"
  openssl x509 -req -in "$id.csr.pem" -CA ca.cert.pem -CAkey ca.key.pem -CAcreateserial -sha256 \
    -days "$days" -out "$id.cert.pem" 2>/dev/null
  rm -f "$id.csr.pem"
  subject="$(openssl x509 -in "$id.cert.pem" -noout -subject -nameopt RFC2253 | sed 's/^subject=//')"
  pub="$(publishes "$id")" sub="$(subscribes "$id")"
  {
    cat <<EOF
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-Security/20170801/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="$id">
      <subject_name>$subject</subject_name>
      <validity><not_before>$not_before</not_before><not_after>$not_after</not_after></validity>
EOF
    if [[ -n "$pub$sub" ]]; then
      echo "      <allow_rule>"
      echo "        <domains><id_range><min>$dmin</min><max>$dmax</max></id_range></domains>"
      if [[ -n "$pub" ]]; then
        echo "        <publish><topics>"
        topics_xml "$pub"
        echo "        </topics></publish>"
      fi
      if [[ -n "$sub" ]]; then
        echo "        <subscribe><topics>"
        topics_xml "$sub"
        echo "        </topics></subscribe>"
      fi
      echo "      </allow_rule>"
    fi
    cat <<EOF
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
EOF
  } >"$id.permissions.xml"
  sign "$id.permissions"
done
write_crl
chmod 0644 ./*.cert.pem ./*.xml ./*.p7s
echo "DDS Security material in $(pwd): CA, revocation list, governance, ${#identities[@]} identities"
