#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Test certificates, made at test time with the openssl CLI (Debian's openssl package), into DIR:
#   ca.pem ca.key                the test CA
#   hub.pem hub.key              the hub: localhost and 127.0.0.1, signed by the CA
#   wrong-host.pem .key          signed by the CA for other.example only
#   expired.pem .key             localhost and 127.0.0.1, signed by the CA, expired yesterday
#   self-signed.pem .key         localhost and 127.0.0.1, signed by itself
#   client.pem client.key        a client certificate signed by the CA (CN=robot-client)
#   rogue-client.pem .key        a client certificate signed by itself
# Usage: make_test_certs.sh DIR
set -eu
dir=$1
mkdir -p "$dir"
cd "$dir"
key() { openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$1" 2>/dev/null; }
# sign NAME CN DAYS SAN: NAME.pem signed by the CA (SAN empty: a client certificate)
sign() {
  key "$1.key"
  openssl req -new -key "$1.key" -subj "/CN=$2" -out "$1.csr" 2>/dev/null
  if [ -n "$4" ]; then
    printf 'subjectAltName=%s\nextendedKeyUsage=serverAuth\n' "$4" >"$1.ext"
  else
    printf 'extendedKeyUsage=clientAuth\n' >"$1.ext"
  fi
  openssl x509 -req -in "$1.csr" -CA ca.pem -CAkey ca.key -CAcreateserial -days "$3" \
    -extfile "$1.ext" -out "$1.pem" 2>/dev/null
  rm -f "$1.csr" "$1.ext"
}
key ca.key
openssl req -x509 -new -key ca.key -subj "/CN=skrobot test CA" -days 2 -out ca.pem 2>/dev/null
sign hub localhost 2 "DNS:localhost,IP:127.0.0.1"
sign wrong-host other.example 2 "DNS:other.example"
sign expired localhost -1 "DNS:localhost,IP:127.0.0.1"
sign client robot-client 2 ""
key self-signed.key
openssl req -x509 -new -key self-signed.key -subj "/CN=localhost" -days 2 \
  -addext "subjectAltName=DNS:localhost,IP:127.0.0.1" -out self-signed.pem 2>/dev/null
key rogue-client.key
openssl req -x509 -new -key rogue-client.key -subj "/CN=rogue-client" -days 2 \
  -out rogue-client.pem 2>/dev/null
