// grid.h: uniform-grid neighbour search shared by every chapter (host: ugpcl.grid.UniformGrid; kernels: grid.cl).
//
// After UniformGrid.build() the items are sorted by cell:
//   keys[k]       = ((ulong)cell << 32) | item index, ascending (k < n)
//   cell_start[c] = first k of cell c, cell_end[c] = one past its last (start == end: empty cell)
// A chapter's kernel visits the items of the 3x3x3 cells around a position (3x3 in 2D) with the one neighbour loop
// below; cell_size >= the search radius makes that exact (every item within the radius is in those cells):
//
//   GridNeighbours it = grid_neighbours(position, origin.xyz, cell_size, dims);
//   int j;
//   while (grid_next_neighbour(&it, keys, cell_start, cell_end, &j)) { ... item j ... }
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

// Where the neighbour loop stands: the home cell, the next of its 27 neighbour cells to open, and the range
// [k, end) of sorted keys left in the cell it has open. Cells are opened in the order of the nested loops
// `for dz, for dy, for dx` (dx fastest), i.e. in increasing cell id, and each cell's items come in increasing index
// (the sort puts them so). Kernels that sum over neighbours therefore add the same terms in the same order on every
// run, and a kernel whose items are stored sorted by this grid's cell sees them in increasing index.
typedef struct {
    int4 home;   // cell of the position (clamped into the grid)
    int4 dims;   // grid size in cells
    int offset;  // next neighbour cell to open: (dx, dy, dz) = (offset % 3, offset / 3 % 3, offset / 9) - 1
    int last;    // one past the last offset: 27, or 18 for a 2D grid
    int k, end;  // keys of the open cell still to visit
} GridNeighbours;

// Start the loop over the items in the cells around `position` (dims.z == 1: the 9 cells of the dz = 0 layer).
inline GridNeighbours grid_neighbours(float3 position, float3 origin, float cell_size, int4 dims) {
    GridNeighbours it;
    it.home = grid_cell_coord(position, origin, cell_size, dims);
    it.dims = dims;
    it.offset = dims.z > 1 ? 0 : 9;  // 2D: the dz = -1 and dz = +1 layers are outside the grid, skip them
    it.last = dims.z > 1 ? 27 : 18;
    it.k = it.end = 0;
    return it;
}

// The next item of the loop in *item; false once every cell has been visited. Cells beyond the grid's border
// (the home cell is a border cell) are skipped.
inline bool grid_next_neighbour(GridNeighbours* it, const __global ulong* keys, const __global int* cell_start,
                                const __global int* cell_end, int* item) {
    while (it->k == it->end) {  // the open cell is used up: open the next one that exists
        if (it->offset == it->last) return false;
        const int o = it->offset++;
        const int cell = grid_cell_id(it->home + (int4)(o % 3 - 1, o / 3 % 3 - 1, o / 9 - 1, 0), it->dims);
        if (cell < 0) continue;  // outside the grid
        it->k = cell_start[cell];
        it->end = cell_end[cell];
    }
    *item = grid_item(keys[it->k++]);
    return true;
}

// }}}

#endif
