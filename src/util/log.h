// Logging through spdlog with a rank prefix ("[facecap r1/3]") once the MPI layer has set it.
// Only rank 0 logs at info level by default; every rank logs warnings and errors.
#ifndef FACECAP_UTIL_LOG_H_
#define FACECAP_UTIL_LOG_H_

#include <string>

#include <spdlog/spdlog.h>

namespace facecap {

// Sets the rank prefix and the level: rank 0 at `level`, other ranks at warn unless
// all_ranks_info is true.
void ConfigureLogging(int rank, int size, spdlog::level::level_enum level = spdlog::level::info,
                      bool all_ranks_info = false);
int LogRank();
int LogSize();

}  // namespace facecap

#define FC_INFO(...) spdlog::info(__VA_ARGS__)
#define FC_WARN(...) spdlog::warn(__VA_ARGS__)
#define FC_ERROR(...) spdlog::error(__VA_ARGS__)
#define FC_DEBUG(...) spdlog::debug(__VA_ARGS__)

#endif  // FACECAP_UTIL_LOG_H_
