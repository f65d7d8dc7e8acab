static const casadi_real ca_bd[CA_NQ] = {@values@};
#define CA_U_FROM_QDOT(j, v) ((v) / ca_bd[j])
#define CA_K_FROM_U(j, v) (ca_bd[j] * (v))
