#!/usr/bin/env python3
"""Surfaces of mesh families FreeSurfer does not write, made from the real data in ../shared/data,
for bench/bench_mesh_families.sh and the tests that check Authalic's maps beyond FreeSurfer meshes.

  mesh_families.py noise SURFACE OUT --sigma MM --seed N        Gaussian noise on every coordinate
  mesh_families.py decimate SURFACE LABEL OUT --reduction R     VTK quadric decimation (R = share removed)
  mesh_families.py voxelise SURFACE LABEL OUT --voxel MM        the enclosed volume on a grid, then
                                                                 marching cubes (flying edges) and
                                                                 windowed-sinc smoothing, as surfaces
                                                                 from a segmentation are made
  mesh_families.py hull GM WM OUT --sigma MM                    whole-brain surface of MNI152's grey +
                                                                 white matter (p > 0.5, Gaussian sigma)
  mesh_families.py bulb OUT                                     an ellipsoid with a 3 mm bulb on a
                                                                 1.2 mm neck (a known failure, docs/robustness.md)
  mesh_families.py labels SURFACE LABEL OUT_PREFIX --seed N     other cortex labels of the same surface
                                                                 (0/1 text masks OUT_PREFIX<name>.txt), as
                                                                 other subjects' and pipelines' labels differ:
                                                                 grown by 2 and 5 vertex rings, shrunk by 3
                                                                 and 10, a ragged border (random bites, 6
                                                                 rounds), and a 12 mm ball cut out of the
                                                                 cortex (holes the cleanup fills)

With LABEL (FreeSurfer .label of SURFACE's vertices), OUT's label (OUT with .label for .surf.gii)
holds the output vertices whose nearest input vertex is in it. Outputs are GIFTI, RAS mm, faces
counter-clockwise seen from outside. Needs /usr/bin/python3 with numpy, scipy, nibabel, vtk (9).
"""
import argparse
import sys

import nibabel as nib
import numpy as np


def read_surface(path):
    if path.endswith(".gii") or path.endswith(".gii.gz"):
        g = nib.load(path)
        return g.darrays[0].data.astype(float), g.darrays[1].data.astype(np.int64)
    V, F = nib.freesurfer.read_geometry(path)
    return V.astype(float), F.astype(np.int64)


def write_surface(path, V, F):
    arrays = [nib.gifti.GiftiDataArray(V.astype(np.float32), intent="NIFTI_INTENT_POINTSET"),
              nib.gifti.GiftiDataArray(F.astype(np.int32), intent="NIFTI_INTENT_TRIANGLE")]
    nib.save(nib.gifti.GiftiImage(darrays=arrays), path)


def outward(V, F):
    """F with every face reversed when the enclosed (signed) volume is negative."""
    vol = np.einsum("ij,ij->i", V[F[:, 0]], np.cross(V[F[:, 1]], V[F[:, 2]])).sum() / 6
    return F[:, [0, 2, 1]] if vol < 0 else F


def transfer_label(src_V, label_path, V, out_path):
    from scipy.spatial import cKDTree
    inside = np.zeros(len(src_V), bool)
    inside[np.loadtxt(label_path, skiprows=2, ndmin=2)[:, 0].astype(int)] = True
    _, nearest = cKDTree(src_V).query(V)
    keep = np.flatnonzero(inside[nearest])
    with open(out_path, "w") as f:
        f.write(f"#!ascii label, transferred from {label_path} by nearest vertex\n{len(keep)}\n")
        for k in keep:
            f.write(f"{k} {V[k, 0]:.3f} {V[k, 1]:.3f} {V[k, 2]:.3f} 0.0\n")


def to_vtk(V, F):
    import vtk
    from vtk.util import numpy_support as ns
    points = vtk.vtkPoints()
    points.SetData(ns.numpy_to_vtk(np.ascontiguousarray(V), deep=1))
    cells = vtk.vtkCellArray()
    cells.SetCells(len(F), ns.numpy_to_vtkIdTypeArray(np.hstack([np.full((len(F), 1), 3), F]).ravel().astype(np.int64), deep=1))
    pd = vtk.vtkPolyData()
    pd.SetPoints(points)
    pd.SetPolys(cells)
    return pd


def from_vtk(pd):
    import vtk
    from vtk.util import numpy_support as ns
    tri = vtk.vtkTriangleFilter()
    tri.SetInputData(pd)
    tri.Update()
    pd = tri.GetOutput()
    V = ns.vtk_to_numpy(pd.GetPoints().GetData()).astype(float)
    F = ns.vtk_to_numpy(pd.GetPolys().GetData()).reshape(-1, 4)[:, 1:].astype(np.int64)
    return V, F


def isosurface(image, level, smooth_iterations=0):
    """The largest connected piece of the level set of a vtkImageData, cleaned (and smoothed)."""
    import vtk
    mc = vtk.vtkFlyingEdges3D()
    mc.SetInputData(image)
    mc.SetValue(0, level)
    largest = vtk.vtkPolyDataConnectivityFilter()
    largest.SetInputConnection(mc.GetOutputPort())
    largest.SetExtractionModeToLargestRegion()
    clean = vtk.vtkCleanPolyData()
    clean.SetInputConnection(largest.GetOutputPort())
    last = clean
    if smooth_iterations > 0:
        smooth = vtk.vtkWindowedSincPolyDataFilter()
        smooth.SetInputConnection(clean.GetOutputPort())
        smooth.SetNumberOfIterations(smooth_iterations)
        smooth.SetPassBand(0.1)
        smooth.NormalizeCoordinatesOn()
        last = smooth
    last.Update()
    V, F = from_vtk(last.GetOutput())
    return V, outward(V, F)


def image_of(values, spacing, origin):
    import vtk
    from vtk.util import numpy_support as ns
    image = vtk.vtkImageData()
    image.SetDimensions(*values.shape)
    image.SetSpacing(spacing, spacing, spacing)
    image.SetOrigin(*origin)
    image.GetPointData().SetScalars(ns.numpy_to_vtk(values.ravel(order="F").astype(np.float32), deep=1))
    return image


def noise(a):
    V, F = read_surface(a.surface)
    V = V + np.random.default_rng(a.seed).normal(0.0, a.sigma, V.shape)
    write_surface(a.out, V, F)


def decimate(a):
    import vtk
    V0, F0 = read_surface(a.surface)
    q = vtk.vtkQuadricDecimation()
    q.SetInputData(to_vtk(V0, F0))
    q.SetTargetReduction(a.reduction)
    q.Update()
    V, F = from_vtk(q.GetOutput())
    write_surface(a.out, V, F)
    transfer_label(V0, a.label, V, label_path(a.out))


def voxelise(a):
    import vtk
    V0, F0 = read_surface(a.surface)
    h = a.voxel
    lo = V0.min(axis=0) - 3
    dims = np.ceil((V0.max(axis=0) + 3 - lo) / h).astype(int) + 1
    image = vtk.vtkImageData()
    image.SetOrigin(*lo)
    image.SetSpacing(h, h, h)
    image.SetDimensions(*dims)
    image.AllocateScalars(vtk.VTK_UNSIGNED_CHAR, 1)
    image.GetPointData().GetScalars().Fill(1)
    stencil = vtk.vtkPolyDataToImageStencil()
    stencil.SetInputData(to_vtk(V0, F0))
    stencil.SetOutputOrigin(*lo)
    stencil.SetOutputSpacing(h, h, h)
    stencil.SetOutputWholeExtent(image.GetExtent())
    inside = vtk.vtkImageStencil()
    inside.SetInputData(image)
    inside.SetStencilConnection(stencil.GetOutputPort())
    inside.ReverseStencilOff()
    inside.SetBackgroundValue(0)
    inside.Update()
    V, F = isosurface(inside.GetOutput(), 0.5, smooth_iterations=20)
    write_surface(a.out, V, F)
    transfer_label(V0, a.label, V, label_path(a.out))


def hull(a):
    from scipy import ndimage
    gm, wm = nib.load(a.gm), nib.load(a.wm)
    brain = gm.get_fdata() + wm.get_fdata() > 0.5
    parts, _ = ndimage.label(brain)
    brain = parts == np.argmax(np.bincount(parts.ravel())[1:]) + 1
    brain = np.pad(ndimage.binary_fill_holes(brain), 4).astype(float)  # closed at the volume's edge
    V, F = isosurface(image_of(ndimage.gaussian_filter(brain, a.sigma), 1.0, (-4, -4, -4)), 0.5)
    V = nib.affines.apply_affine(gm.affine, V)
    write_surface(a.out, V, outward(V, F))


def bulb(a):
    # Ellipsoid 25 x 35 x 30 mm (semi-axes); on +y a bulb of radius 3 mm on a neck of radius 1.2 mm
    # and length 2 mm: 1 % of the area behind a neck of 7.5 mm circumference.
    ax, ay, az, rb, rn, ln, h = 25.0, 35.0, 30.0, 3.0, 1.2, 2.0, 0.6
    lim = np.array([ax, ay + ln + 2 * rb + 3, az])
    axes = [np.arange(-l - 3, l + 3 + h, h) for l in lim]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    body = (np.sqrt((X / ax) ** 2 + (Y / ay) ** 2 + (Z / az) ** 2) - 1) * min(ax, ay, az)
    yc = ay + ln + rb
    knob = np.sqrt(X ** 2 + (Y - yc) ** 2 + Z ** 2) - rb
    neck = np.maximum(np.sqrt(X ** 2 + Z ** 2) - rn, np.maximum(ay - 2 - Y, Y - yc))
    V, F = isosurface(image_of(np.minimum(np.minimum(body, knob), neck), h, [x[0] for x in axes]), 0.0)
    write_surface(a.out, V, F)


def labels(a):
    import scipy.sparse as sp
    V, F = read_surface(a.surface)
    n = len(V)
    inside = np.zeros(n, bool)
    inside[np.loadtxt(a.label, skiprows=2, ndmin=2)[:, 0].astype(int)] = True
    i = np.concatenate([F[:, 0], F[:, 1], F[:, 2]])
    j = np.concatenate([F[:, 1], F[:, 2], F[:, 0]])
    A = sp.csr_matrix((np.ones(2 * len(i)), (np.concatenate([i, j]), np.concatenate([j, i]))), shape=(n, n))

    def grow(mask, rings):
        for _ in range(rings):
            mask = mask | (A @ mask.astype(float) > 0)
        return mask

    def shrink(mask, rings):
        return ~grow(~mask, rings)

    rng = np.random.default_rng(a.seed)
    ragged = inside.copy()
    for _ in range(6):  # half of the border vertices, at random, six times
        border = np.flatnonzero(ragged & (A @ (~ragged).astype(float) > 0))
        ragged[rng.choice(border, len(border) // 2, replace=False)] = False
    centre = rng.choice(np.flatnonzero(shrink(inside, 30)))
    variants = {"grown2": grow(inside, 2), "grown5": grow(inside, 5), "shrunk3": shrink(inside, 3),
                "shrunk10": shrink(inside, 10), "ragged": ragged,
                "cut12mm": inside & (np.linalg.norm(V - V[centre], axis=1) > 12)}
    for name, mask in variants.items():
        np.savetxt(a.out_prefix + name + ".txt", mask.astype(int), fmt="%d")


def label_path(out):
    return out[: -len(".surf.gii")] + ".label" if out.endswith(".surf.gii") else out + ".label"


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="family", required=True)
    s = sub.add_parser("noise"); s.add_argument("surface"); s.add_argument("out")
    s.add_argument("--sigma", type=float, required=True); s.add_argument("--seed", type=int, default=1)
    s.set_defaults(run=noise)
    s = sub.add_parser("decimate"); s.add_argument("surface"); s.add_argument("label"); s.add_argument("out")
    s.add_argument("--reduction", type=float, required=True); s.set_defaults(run=decimate)
    s = sub.add_parser("voxelise"); s.add_argument("surface"); s.add_argument("label"); s.add_argument("out")
    s.add_argument("--voxel", type=float, required=True); s.set_defaults(run=voxelise)
    s = sub.add_parser("hull"); s.add_argument("gm"); s.add_argument("wm"); s.add_argument("out")
    s.add_argument("--sigma", type=float, default=2.0); s.set_defaults(run=hull)
    s = sub.add_parser("bulb"); s.add_argument("out"); s.set_defaults(run=bulb)
    s = sub.add_parser("labels"); s.add_argument("surface"); s.add_argument("label"); s.add_argument("out_prefix")
    s.add_argument("--seed", type=int, default=1); s.set_defaults(run=labels)
    a = p.parse_args()
    a.run(a)


if __name__ == "__main__":
    sys.exit(main())
