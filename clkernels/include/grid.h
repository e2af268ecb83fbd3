// grid.h: uniform-grid neighbour search shared by every chapter (host: ugpcl.grid.UniformGrid; kernels: grid.cl).
//
// After UniformGrid.build() the items are sorted by cell:
//   keys[k]       = ((ulong)cell << 32) | item index, ascending (k < n)
//   cell_start[c] = first k of cell c, cell_end[c] = one past its last (start == end: empty cell)
// A chapter's kernel visits the items of the 3x3x3 cells around a position (3x3 in 2D) with the one neighbour loop
// below; cell_size >= the search radius makes that exact (every item within the radius is in those cells):
//
//   const int4 home = grid_cell_coord(position, origin.xyz, cell_size, dims);
//   GRID_FOR_EACH_NEIGHBOUR_KEY(k, home, dims, cell_start, cell_end) { const int j = grid_item(keys[k]); ... }
//
// 2D grids use dims.z == 1 (and z = 0 in the position): only the dz = 0 layer is visited, the others being outside.
// Positions outside the grid are clamped into its border cells, which keeps every item findable: clamping never
// moves two points' cells further apart.
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

// {{{ the neighbour loop

// Runs the statement after it once for each sorted key k of each cell of the 3x3x3 block around `home` that lies
// in the grid (on a 2D grid, dims.z == 1, the 3x3 cells of the dz = 0 layer). Cells are visited in the order of the
// nested loops dz, dy, dx (dx fastest), i.e. in increasing cell id, and a cell's keys in increasing item index
// (the sort puts them so): kernels that sum over neighbours add the same terms in the same order on every run, and
// a kernel whose items are stored sorted by this grid's cell sees them in increasing index. `continue` goes on to
// the next key; `break` leaves only the current cell.
// A macro rather than an iterator function: it keeps the plain nested loops (dy, dx with constant bounds) that the
// compilers unroll and PoCL vectorises (an iterator struct stepped in a while loop ran the boids' grid variant 1.7x
// slower on a 16-core PoCL).
#define GRID_FOR_EACH_NEIGHBOUR_KEY(k, home, dims, cell_start, cell_end)                                             \
    for (int grid_dz_ = (dims).z > 1 ? -1 : 0; grid_dz_ <= ((dims).z > 1 ? 1 : 0); grid_dz_++)                        \
        for (int grid_dy_ = -1; grid_dy_ <= 1; grid_dy_++)                                                           \
            for (int grid_dx_ = -1; grid_dx_ <= 1; grid_dx_++)                                                       \
                for (int grid_cell_ = grid_cell_id((home) + (int4)(grid_dx_, grid_dy_, grid_dz_, 0), (dims)),        \
                         k = grid_cell_ < 0 ? 0 : (cell_start)[grid_cell_],  /* outside the grid: no keys */          \
                         grid_end_ = grid_cell_ < 0 ? 0 : (cell_end)[grid_cell_];                                    \
                     k < grid_end_; k++)

// }}}

#endif
