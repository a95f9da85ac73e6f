extern const int vdbs_placeholder_vdbio; const int vdbs_placeholder_vdbio = 0;
