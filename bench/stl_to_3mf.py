#!/usr/bin/env python3
"""Writes an ASCII STL as two 3MF packages holding the same mesh, to compare the 3MF readers:

  OUT_DIR/components.3mf  the Bambu Studio / OrcaSlicer layout: the mesh in
                          3D/Objects/object_1.model, placed from the root model by a
                          <component p:path=...> and a build item (read by printtwin itself)
  OUT_DIR/flat.3mf        the PrusaSlicer layout: the mesh in the root model (read by assimp)

Usage: bench/stl_to_3mf.py build/benchdata/bench_model.stl OUT_DIR
Vertices are joined by their text, so both packages hold the welded mesh the STL describes.
"""
import os
import sys
import zipfile

HEAD = ('<?xml version="1.0" encoding="UTF-8"?>\n<model unit="millimeter" xml:lang="en-US" '
        'xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02" '
        'xmlns:p="http://schemas.microsoft.com/3dmanufacturing/production/2015/06" '
        'requiredextensions="p">\n <resources>\n')
RELS = ('<?xml version="1.0" encoding="UTF-8"?>\n<Relationships '
        'xmlns="http://schemas.openxmlformats.org/package/2006/relationships">\n <Relationship '
        'Target="/3D/3dmodel.model" Id="rel-1" '
        'Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/>\n</Relationships>\n')
TYPES = ('<?xml version="1.0" encoding="UTF-8"?>\n<Types '
         'xmlns="http://schemas.openxmlformats.org/package/2006/content-types"><Default '
         'Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/>'
         '<Default Extension="model" '
         'ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/></Types>\n')
IDENTITY = "1 0 0 0 1 0 0 0 1 0 0 0"


def read_ascii_stl(path):
    tokens = open(path).read().split()
    index, vertices, triangles, corners = {}, [], [], []
    i = 0
    while i < len(tokens):
        if tokens[i] != "vertex":
            i += 1
            continue
        key = tuple(tokens[i + 1:i + 4])
        if key not in index:
            index[key] = len(vertices)
            vertices.append(key)
        corners.append(index[key])
        if len(corners) == 3:
            triangles.append(corners)
            corners = []
        i += 4
    return vertices, triangles


def mesh_xml(vertices, triangles):
    parts = ["   <mesh>\n    <vertices>\n"]
    parts += ['     <vertex x="%s" y="%s" z="%s"/>\n' % v for v in vertices]
    parts.append("    </vertices>\n    <triangles>\n")
    parts += ['     <triangle v1="%d" v2="%d" v3="%d"/>\n' % tuple(t) for t in triangles]
    parts.append("    </triangles>\n   </mesh>\n")
    return "".join(parts)


def write_zip(path, entries):
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for name, text in entries:
            z.writestr(name, text)


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    vertices, triangles = read_ascii_stl(sys.argv[1])
    mesh = mesh_xml(vertices, triangles)
    out = sys.argv[2]
    os.makedirs(out, exist_ok=True)
    obj = HEAD + '  <object id="1" type="model">\n' + mesh + "  </object>\n </resources>\n</model>\n"
    root = (HEAD + '  <object id="2" type="model">\n   <components>\n    <component '
            'p:path="/3D/Objects/object_1.model" objectid="1" transform="' + IDENTITY + '"/>\n'
            '   </components>\n  </object>\n </resources>\n <build>\n  <item objectid="2" '
            'transform="' + IDENTITY + '" printable="1"/>\n </build>\n</model>\n')
    write_zip(os.path.join(out, "components.3mf"),
              [("[Content_Types].xml", TYPES), ("_rels/.rels", RELS),
               ("3D/Objects/object_1.model", obj), ("3D/3dmodel.model", root)])
    flat = (HEAD + '  <object id="1" type="model">\n' + mesh + "  </object>\n </resources>\n"
            ' <build>\n  <item objectid="1" transform="' + IDENTITY + '"/>\n </build>\n</model>\n')
    write_zip(os.path.join(out, "flat.3mf"),
              [("[Content_Types].xml", TYPES), ("_rels/.rels", RELS), ("3D/3dmodel.model", flat)])
    print("%d vertices, %d triangles" % (len(vertices), len(triangles)))


if __name__ == "__main__":
    main()
