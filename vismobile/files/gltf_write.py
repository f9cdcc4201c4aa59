"""A small GLB writer for animated scenes (pygltflib): the examples, the tests and the fuzzer's
seed files make their animated inputs with it; gltf_anim.py reads them back."""
from __future__ import annotations

import numpy as np

from .atomic import atomic_write_bytes


def animated_glb(path, meshes, channels=(), parents=None) -> None:
    """Write a GLB, atomically: one node per mesh, its channels in one animation.

    meshes   : list of dicts name, vertices (n, 3), faces (m, 3) and optional rest
               translation (3,), rotation (4,) x y z w, scale (3,)
    channels : list of (node index, path 'translation' | 'rotation' | 'scale', times (K,),
               values (K, width), interpolation 'LINEAR' | 'STEP' | 'CUBICSPLINE')
    parents  : optional list, parent node index of each node (None: a root)
    """
    import pygltflib as g

    blob = bytearray()
    accessors, views = [], []

    def add(array, component, kind, target=None):
        array = np.ascontiguousarray(array)
        while len(blob) % 4:
            blob.append(0)
        views.append(g.BufferView(buffer=0, byteOffset=len(blob), byteLength=array.nbytes,
                                  target=target))
        blob.extend(array.tobytes())
        flat = array.reshape(len(array), -1)
        accessors.append(g.Accessor(bufferView=len(views) - 1, componentType=component,
                                    count=len(array), type=kind,
                                    max=flat.max(axis=0).tolist() if component == g.FLOAT
                                    else None,
                                    min=flat.min(axis=0).tolist() if component == g.FLOAT
                                    else None))
        return len(accessors) - 1

    nodes, gmeshes = [], []
    for k, mesh in enumerate(meshes):
        position = add(np.asarray(mesh["vertices"], np.float32), g.FLOAT, g.VEC3, g.ARRAY_BUFFER)
        indices = add(np.asarray(mesh["faces"], np.uint32).reshape(-1), g.UNSIGNED_INT,
                      g.SCALAR, g.ELEMENT_ARRAY_BUFFER)
        gmeshes.append(g.Mesh(primitives=[g.Primitive(attributes=g.Attributes(
            POSITION=position), indices=indices)]))
        node = g.Node(mesh=k, name=mesh["name"])
        for key in ("translation", "rotation", "scale"):
            if mesh.get(key) is not None:
                setattr(node, key, [float(v) for v in mesh[key]])
        nodes.append(node)
    parents = parents or [None] * len(nodes)
    for child, parent in enumerate(parents):
        if parent is not None:
            nodes[parent].children = (nodes[parent].children or []) + [child]
    samplers, gchannels = [], []
    for node, target, times, values, interpolation in channels:
        inp = add(np.asarray(times, np.float32), g.FLOAT, g.SCALAR)
        out = add(np.asarray(values, np.float32), g.FLOAT, {3: g.VEC3, 4: g.VEC4}[
            np.asarray(values).shape[-1]])
        samplers.append(g.AnimationSampler(input=inp, output=out, interpolation=interpolation))
        gchannels.append(g.AnimationChannel(sampler=len(samplers) - 1,
                                            target=g.AnimationChannelTarget(node=node, path=target)))
    gltf = g.GLTF2(scene=0, scenes=[g.Scene(nodes=[k for k, p in enumerate(parents)
                                                   if p is None])],
                   nodes=nodes, meshes=gmeshes, accessors=accessors, bufferViews=views,
                   buffers=[g.Buffer(byteLength=len(blob))],
                   animations=[g.Animation(samplers=samplers, channels=gchannels)]
                   if gchannels else [])
    gltf.set_binary_blob(bytes(blob))
    atomic_write_bytes(path, b"".join(gltf.save_to_bytes()))
