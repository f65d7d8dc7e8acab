#define CA_U_FROM_QDOT(j, v) (v)
#define CA_K_FROM_U(j, v) (v)
