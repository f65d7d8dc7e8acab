  for (j = 0; j < CA_M - 1; ++j) if (packed[CA_OUT_LINK_MARGINS + j] == 0) return COORDARM_LAW_ESINGULAR;
  if (packed[CA_OUT_END_MARGIN] == 0) return COORDARM_LAW_ESINGULAR;
  for (j = 0; j < CA_M; ++j) if (packed[CA_OUT_JOINT_MARGINS + j] == 0) return COORDARM_LAW_ESINGULAR;
