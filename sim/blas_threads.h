#pragma once
// One BLAS thread for a scope. CHOLMOD's supernodal solves call BLAS; with OpenBLAS (what the
// Makefile installs) each call may wake its worker threads, which then spin for a while after it.
// For the small triangular solves of the coarse model that costs more than it gives, and while the
// refinement's own threads run their element passes the spinning threads take their cores
// (measured: a refinement step 0.51 -> 0.40 s, its products 0.17 -> 0.10 s, on 2 cores). The large
// factorizations of the fine reference keep every BLAS thread: only these scopes change it.
// Found at run time (the BLAS library is whichever one the system's alternatives chose); with a
// BLAS that has no such call this does nothing.
#include <dlfcn.h>

namespace handson {

class SingleThreadedBlas {
 public:
  SingleThreadedBlas() {
    static const auto fns = lookup();
    if (!fns.set || !fns.get) return;
    set_ = fns.set;
    previous_ = fns.get();
    if (previous_ > 1) set_(1);
  }
  ~SingleThreadedBlas() {
    if (set_ && previous_ > 1) set_(previous_);
  }
  SingleThreadedBlas(const SingleThreadedBlas&) = delete;
  SingleThreadedBlas& operator=(const SingleThreadedBlas&) = delete;

 private:
  using SetFn = void (*)(int);
  using GetFn = int (*)();
  struct Fns {
    SetFn set = nullptr;
    GetFn get = nullptr;
  };
  static Fns lookup() {
    Fns f;
    f.set = reinterpret_cast<SetFn>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
    f.get = reinterpret_cast<GetFn>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
    return f;
  }
  SetFn set_ = nullptr;
  int previous_ = 1;
};

}  // namespace handson
