// irgrid/irgrid.h: the whole public API of the irgrid library in one include.
//
// irgrid builds irregular grids (Pérard-Gayot, Kalojanov, Slusallek, "GPU Ray Tracing using
// Irregular Grids", Eurographics 2017) over triangle meshes and traces rays through them on the
// CPU and on NVIDIA GPUs. docs/api.md is the reference, with a complete example.
#pragma once

#include "irgrid/accelerator.h"   // make_accelerator, Accelerator, Structure, Backend, BuildStats
#include "irgrid/build_config.h"  // BuildConfig: the grid's construction parameters
#include "irgrid/error.h"         // Error, ErrorCode
#include "irgrid/kernel.h"        // closest_hit / any_hit for one ray, from your own kernels
#include "irgrid/mesh.h"          // TriangleMesh: your vertex and index arrays
#include "irgrid/ray.h"           // Ray, Hit, Query
#include "irgrid/system.h"        // version, cuda_status
