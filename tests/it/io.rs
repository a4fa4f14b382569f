//! `trimorph::io`: ITK `.h5` fields ([`itk`]), OME-Zarr ([`ngff`]) and BigWarp 3D landmark
//! tables ([`bigwarp_3d`]).

mod bigwarp_3d;
mod itk;
mod ngff;
