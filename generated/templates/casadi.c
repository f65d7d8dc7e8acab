#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-parameter"

@functions@
#pragma GCC diagnostic pop
