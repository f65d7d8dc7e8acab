#!/bin/sh
# Re-extract the official Foxglove JSON Schemas shipped here from the published npm package
# @foxglove/schemas (generated from the foxglove-sdk repository's schemas/jsonschema), byte for byte
# as the package defines them. Needs npm and node; run from this folder:  sh update.sh [VERSION]
set -eu
VERSION="${1:-2.1.0}"
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT
(cd "$TMP" && npm pack --silent "@foxglove/schemas@$VERSION" >/dev/null && tar xzf foxglove-schemas-*.tgz)
HERE="$(pwd)"
for NAME in SceneUpdate FrameTransforms; do
  node -e 'const s = require(process.argv[1] + "/package/dist/jsonschema/index.js");
           process.stdout.write(JSON.stringify(s[process.argv[2]], null, 2) + "\n");' \
    "$TMP" "$NAME" > "$HERE/foxglove.$NAME.json"
done
echo "$VERSION" > "$HERE/VERSION"
