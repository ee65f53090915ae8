// Writes small CGNS seeds for fuzz_cgns into the current directory with libcgns itself (scripts/fuzz.sh compiles and
// runs it): a structured zone with a CellCenter solution (X/Y/Z momentum), and two hexahedra as HEXA_8, as MIXED and
// as NFACE_n/NGON_n with a Vertex solution, each as ADF and as HDF5. The shared sample (1 MB) is a seed too.
#include <cgnslib.h>
#include <stdio.h>
#include <math.h>
static void coords(int fn, int B, int Z, int n, double* x, double* y, double* z) {
  int C; cg_coord_write(fn,B,Z,RealDouble,"CoordinateX",x,&C); cg_coord_write(fn,B,Z,RealDouble,"CoordinateY",y,&C); cg_coord_write(fn,B,Z,RealDouble,"CoordinateZ",z,&C);
}
int main(void) {
  for (int t = 0; t < 2; ++t) {
    cg_set_file_type(t ? CG_FILE_HDF5 : CG_FILE_ADF);
    char name[64]; int fn, B, Z, S, F, sol;
    /* structured 3x3x2 with a cell solution and rind */
    sprintf(name, "struct%d.cgns", t); cg_open(name, CG_MODE_WRITE, &fn); cg_base_write(fn,"B",3,3,&B);
    cgsize_t s[9] = {3,3,2,2,2,1,0,0,0}; cg_zone_write(fn,B,"Z",s,Structured,&Z);
    double x[18],y[18],z[18]; int k=0; for(int c=0;c<2;++c)for(int j=0;j<3;++j)for(int i=0;i<3;++i){x[k]=i;y[k]=j;z[k]=c;++k;}
    coords(fn,B,Z,18,x,y,z); cg_sol_write(fn,B,Z,"S",CellCenter,&sol); double v[4]={1,2,3,4}; cg_field_write(fn,B,Z,sol,RealDouble,"Density",v,&F);
    double mx[4]={1,1,1,1}; cg_field_write(fn,B,Z,sol,RealDouble,"MomentumX",mx,&F); cg_field_write(fn,B,Z,sol,RealDouble,"MomentumY",mx,&F); cg_field_write(fn,B,Z,sol,RealDouble,"MomentumZ",mx,&F);
    cg_close(fn);
    /* unstructured: 2 hexes as HEXA_8, the same as MIXED, and as NFACE/NGON, with a vertex solution */
    for (int layout = 0; layout < 3; ++layout) {
      sprintf(name, "unstr%d_%d.cgns", t, layout); cg_open(name, CG_MODE_WRITE, &fn); cg_base_write(fn,"B",3,3,&B);
      cgsize_t s2[3] = {12,2,0}; cg_zone_write(fn,B,"U",s2,Unstructured,&Z);
      double ux[12],uy[12],uz[12]; k=0; for(int c=0;c<2;++c)for(int j=0;j<2;++j)for(int i=0;i<3;++i){ux[k]=i;uy[k]=j;uz[k]=c;++k;}
      coords(fn,B,Z,12,ux,uy,uz);
      cgsize_t h[16] = {1,2,5,4,7,8,11,10, 2,3,6,5,8,9,12,11};
      if (layout == 0) cg_section_write(fn,B,Z,"H",HEXA_8,1,2,0,h,&S);
      else if (layout == 1) { cgsize_t m[18]={HEXA_8,1,2,5,4,7,8,11,10, HEXA_8,2,3,6,5,8,9,12,11}; cgsize_t o[3]={0,9,18}; cg_poly_section_write(fn,B,Z,"M",MIXED,1,2,0,m,o,&S); }
      else {
        static const int f[6][4]={{0,4,7,3},{1,2,6,5},{0,1,5,4},{3,7,6,2},{0,3,2,1},{4,5,6,7}};
        cgsize_t faces[48], fo[13], cells[12], co[3]={0,6,12}; fo[0]=0;
        for(int c=0;c<2;++c)for(int q=0;q<6;++q){for(int r=0;r<4;++r)faces[(c*6+q)*4+r]=h[c*8+f[q][r]]; fo[c*6+q+1]=(c*6+q+1)*4; cells[c*6+q]=3+c*6+q;}
        cg_poly_section_write(fn,B,Z,"C",NFACE_n,1,2,0,cells,co,&S); cg_poly_section_write(fn,B,Z,"F",NGON_n,3,14,0,faces,fo,&S);
      }
      cg_sol_write(fn,B,Z,"N",Vertex,&sol); double p[12]; for(int i=0;i<12;++i)p[i]=i; cg_field_write(fn,B,Z,sol,RealDouble,"Pressure",p,&F);
      cg_close(fn);
    }
  }
  return 0;
}
