  for (j = 0; j < CA_M - 1; ++j) if (packed[CA_OUT_LINK_MARGINS + j] == 0) return COORDARM_LAW_ESINGULAR;
  if (packed[CA_OUT_LONGITUDINAL_PIVOT] == 0) return COORDARM_LAW_ESINGULAR;
#if CA_RAIL
  if (packed[CA_OUT_RAIL_MARGIN] == 0) return COORDARM_LAW_ESINGULAR;
#endif
