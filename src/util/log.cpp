#include "util/log.h"

#include <spdlog/sinks/stdout_sinks.h>

namespace facecap {
namespace {
int g_rank = 0;
int g_size = 1;
}  // namespace

void ConfigureLogging(int rank, int size, spdlog::level::level_enum level, bool all_ranks_info) {
  g_rank = rank;
  g_size = size;
  static auto logger = [] {
    auto l = spdlog::stderr_logger_mt("facecap");
    spdlog::set_default_logger(l);
    return l;
  }();
  std::string prefix = size > 1 ? "[%H:%M:%S r" + std::to_string(rank) + "/" +
                                      std::to_string(size) + " %^%l%$] %v"
                                : "[%H:%M:%S %^%l%$] %v";
  logger->set_pattern(prefix);
  logger->set_level(rank == 0 || all_ranks_info ? level : spdlog::level::warn);
  logger->flush_on(spdlog::level::info);
}

int LogRank() { return g_rank; }
int LogSize() { return g_size; }

}  // namespace facecap
