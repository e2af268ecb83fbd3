// grid.h: uniform-grid neighbour search shared by every chapter (host: ugpcl.grid.UniformGrid; kernels: grid.cl).
//
// After UniformGrid.build() the items are sorted by cell:
//   keys[k]       = ((ulong)cell << 32) | item index, ascending (k < n)
//   cell_start[c] = first k of cell c, cell_end[c] = one past its last (start == end: empty cell)
// A neighbour loop over the 3x3x3 cells around a position (cell_size >= search radius makes it exact):
//
//   int4 home = grid_cell_coord(position, origin, cell_size, dims);
//   for (int dz = -1; dz <= 1; dz++) for (int dy = -1; dy <= 1; dy++) for (int dx = -1; dx <= 1; dx++) {
//       int cell = grid_cell_id(home + (int4)(dx, dy, dz, 0), dims);
//       if (cell < 0) continue;                                  // outside the grid
//       for (int k = cell_start[cell]; k < cell_end[cell]; k++) { int j = grid_item(keys[k]); ... }
//   }
// 2D grids use dims.z == 1 (dz = 0 only: the other layers are outside). Positions outside the grid are clamped into
// its border cells, which keeps every item findable: clamping never moves two points' cells further apart.
#ifndef UGPCL_GRID_H
#define UGPCL_GRID_H

#define GRID_EMPTY_KEY 0xFFFFFFFFFFFFFFFFUL  // padding keys sort after every real one

// Cell coordinates of a position, clamped into [0, dims - 1] per axis (w = 0).
inline int4 grid_cell_coord(float3 position, float3 origin, float cell_size, int4 dims) {
    float3 c = floor((position - origin) / cell_size);
    return (int4)(clamp((int)c.x, 0, dims.x - 1), clamp((int)c.y, 0, dims.y - 1), clamp((int)c.z, 0, dims.z - 1), 0);
}

// Linear cell id, or -1 when the coordinates are outside the grid.
inline int grid_cell_id(int4 c, int4 dims) {
    if (c.x < 0 || c.y < 0 || c.z < 0 || c.x >= dims.x || c.y >= dims.y || c.z >= dims.z) return -1;
    return (c.z * dims.y + c.y) * dims.x + c.x;
}

inline int grid_item(ulong key) { return (int)(key & 0xFFFFFFFFUL); }
inline int grid_key_cell(ulong key) { return (int)(key >> 32); }

#endif
