"""Mirror image of a GIFTI surface through the midsagittal plane (x -> -x), triangles as they are:
a left hemisphere stands in for the right one where a benchmark needs both.
    mirror_hemisphere.py IN.surf.gii OUT.surf.gii"""
import sys

import nibabel as nib
import numpy as np

src, dst = sys.argv[1:3]
g = nib.load(src)
P = [a for a in g.darrays if a.intent == 1008][0]
T = [a for a in g.darrays if a.intent == 1009][0]
Q = np.asarray(P.data, np.float32).copy()
Q[:, 0] *= -1
nib.save(nib.gifti.GiftiImage(darrays=[
    nib.gifti.GiftiDataArray(Q, intent='NIFTI_INTENT_POINTSET', datatype='NIFTI_TYPE_FLOAT32'),
    nib.gifti.GiftiDataArray(np.asarray(T.data, np.int32), intent='NIFTI_INTENT_TRIANGLE', datatype='NIFTI_TYPE_INT32')]), dst)
