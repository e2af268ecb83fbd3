#version 430 core
// GPUMarchingCubesRenderStandardMesh.shader (vol.1 ch.7), vert(): passes the point through. The book draws
// point meshes whose vertex j sits at (id % N, (id / N) % N, (id / N^2) % N); here the draw is attribute-less
// and the cell comes from gl_VertexID, for exactly N^3 points.
uniform int segment_num;  // _SegmentNum

flat out ivec3 v_cell;

void main() {
    int id = gl_VertexID;
    v_cell = ivec3(id % segment_num, (id / segment_num) % segment_num, id / (segment_num * segment_num));
    gl_Position = vec4(0.0);  // unused: the geometry shader emits the clip positions
}
