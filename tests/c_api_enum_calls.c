/* Calls of the C API with an enum argument given as a plain int, as a C caller may pass any int (C has
   no undefined behaviour for an enum value outside its enumerators; C++ has, and clang's UBSan also flags
   a call through a function pointer of another type, which the C++ tests used before). */
#include "engine/api/sinew.h"

sinew_status sinew_test_set_solver_int(sinew_world_id world, int solver, int velocity_iterations) {
    return sinew_world_set_solver(world, (sinew_solver)solver, velocity_iterations);
}

sinew_status sinew_test_set_coupling_int(sinew_world_id world, int strategy, float gain) {
    return sinew_world_set_coupling(world, (sinew_coupling)strategy, gain);
}

sinew_status sinew_test_set_body_type_int(sinew_body_id body, int type) {
    return sinew_body_set_type(body, (sinew_body_type)type);
}

sinew_status sinew_test_set_embed_proxies_int(sinew_world_id world, int proxies, int mass) {
    return sinew_world_set_embed_proxies(world, (sinew_embed_proxies)proxies, (sinew_embed_mass)mass);
}
