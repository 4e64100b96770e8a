#!/bin/sh
# Regenerates the sample meshes in samples/models/ from their OpenSCAD sources (needs
# openscad and python3; the test suite does not). Each STL is written as binary STL.
# broken.stl is written by this script directly (an open, non-manifold cube).
#   scripts/make_samples.sh            # all samples
#   scripts/make_samples.sh bridges    # only samples/models/bridges.scad
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
models="$here/samples/models"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# ASCII STL (openscad's output) -> binary STL, vertices as written (float32).
to_binary() {
  python3 - "$1" "$2" <<'PY'
import struct, sys
src, dst = sys.argv[1], sys.argv[2]
tris, cur = [], []
for line in open(src):
    w = line.split()
    if w and w[0] == "vertex":
        cur.append(tuple(float(x) for x in w[1:4]))
        if len(cur) == 3:
            tris.append(cur); cur = []
with open(dst, "wb") as f:
    f.write(b"printtwin sample (scripts/make_samples.sh)".ljust(80, b" "))
    f.write(struct.pack("<I", len(tris)))
    for a, b, c in tris:
        u = [b[i] - a[i] for i in range(3)]; v = [c[i] - a[i] for i in range(3)]
        n = [u[1]*v[2]-u[2]*v[1], u[2]*v[0]-u[0]*v[2], u[0]*v[1]-u[1]*v[0]]
        l = sum(x * x for x in n) ** 0.5 or 1.0
        f.write(struct.pack("<12fH", *(x / l for x in n), *a, *b, *c, 0))
PY
}

make_one() {
  openscad -q -o "$tmp/$1.stl" "$models/$1.scad"
  to_binary "$tmp/$1.stl" "$models/$1.stl"
  echo "$1.stl: $(wc -c < "$models/$1.stl") bytes"
}

if [ $# -gt 0 ]; then
  for name in "$@"; do make_one "$name"; done
  exit 0
fi

for scad in "$models"/*.scad; do
  make_one "$(basename "$scad" .scad)"
done

# broken.stl: a 20 mm cube without its top face (open: 4 boundary edges), a fin triangle
# on a bottom edge (that edge has 3 faces: non-manifold) and one zero-area triangle.
cat > "$models/broken.stl" <<'STL'
solid broken
facet normal 0 0 -1
outer loop
vertex 0 0 0
vertex 0 20 0
vertex 20 20 0
endloop
endfacet
facet normal 0 0 -1
outer loop
vertex 0 0 0
vertex 20 20 0
vertex 20 0 0
endloop
endfacet
facet normal 0 -1 0
outer loop
vertex 0 0 0
vertex 20 0 0
vertex 20 0 20
endloop
endfacet
facet normal 0 -1 0
outer loop
vertex 0 0 0
vertex 20 0 20
vertex 0 0 20
endloop
endfacet
facet normal 0 1 0
outer loop
vertex 0 20 0
vertex 0 20 20
vertex 20 20 20
endloop
endfacet
facet normal 0 1 0
outer loop
vertex 0 20 0
vertex 20 20 20
vertex 20 20 0
endloop
endfacet
facet normal -1 0 0
outer loop
vertex 0 0 0
vertex 0 0 20
vertex 0 20 20
endloop
endfacet
facet normal -1 0 0
outer loop
vertex 0 0 0
vertex 0 20 20
vertex 0 20 0
endloop
endfacet
facet normal 1 0 0
outer loop
vertex 20 0 0
vertex 20 20 0
vertex 20 20 20
endloop
endfacet
facet normal 1 0 0
outer loop
vertex 20 0 0
vertex 20 20 20
vertex 20 0 20
endloop
endfacet
facet normal 0 -0.7071 -0.7071
outer loop
vertex 0 0 0
vertex 20 0 0
vertex 10 -10 10
endloop
endfacet
facet normal 0 0 1
outer loop
vertex 5 5 0
vertex 10 5 0
vertex 15 5 0
endloop
endfacet
endsolid broken
STL
echo "broken.stl: $(wc -c < "$models/broken.stl") bytes"
