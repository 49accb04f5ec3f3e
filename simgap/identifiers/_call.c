/*
 * simgap.identifiers._call: a thin C caller for the single-identifier step kernel.
 *
 * Why it exists: numba's dispatcher spends about 0.3 us per call resolving the types of six
 * arrays and wrapping them, and np.empty for the returned g-hat another 0.1-0.2 us, while
 * the step's own arithmetic takes about 0.4 us (benchmarks/bench_identifiers.py). This
 * module holds the address of a numba cfunc (the same row code as the numba kernel, see
 * simgap/identifiers/fastcall.py), checks the four input arrays with NumPy's C macros,
 * allocates g-hat and calls the cfunc directly. It contains no numerics.
 *
 * Stepper(address, S, n, fallback=None)(x, u, f, x_next) -> g-hat (new float64 array of n
 * values). When an argument is not a float64, 1-D, C-contiguous, aligned array, or the kernel
 * reports a failure (bad sizes, non-finite input, divergence), it returns
 * fallback(x, u, f, x_next), or None without a fallback: the Python side's general path,
 * which converts the arguments or raises the typed error; the kernel leaves a failed row
 * exactly as it was. With a fallback the Stepper can stand in for Identifier.step itself (an
 * instance attribute), which saves the Python frame of the method (about 0.13 us of a
 * 0.4 us step, benchmarks/bench_auto_cost_vs_filing.py).
 *
 * The extension is optional (setup.py): without a C compiler simgap installs without it and
 * Identifier.step calls the numba kernel through numba's dispatcher instead.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stddef.h>
#include <stdint.h>
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>

/* C ABI of the cfunc: (S, rows, cols, x, nx, u, nu, f, nf, x_next, nx_next, g, ng) -> code,
 * 0 = success. */
typedef int64_t (*step_kernel)(double *, int64_t, int64_t, double *, int64_t, double *,
                               int64_t, double *, int64_t, double *, int64_t, double *,
                               int64_t);

typedef struct {
    PyObject_HEAD
    vectorcallfunc vectorcall;
    step_kernel kernel;
    PyArrayObject *state;
    PyObject *fallback; /* NULL: return None instead */
    npy_intp n;
} Stepper;

static inline int is_input(PyObject *o) {
    return PyArray_Check(o) && PyArray_TYPE((PyArrayObject *)o) == NPY_DOUBLE
           && PyArray_NDIM((PyArrayObject *)o) == 1
           && PyArray_ISCARRAY_RO((PyArrayObject *)o);
}

#define DATA(o) ((double *)PyArray_DATA((PyArrayObject *)(o)))
#define LEN(o) ((int64_t)PyArray_DIM((PyArrayObject *)(o), 0))

/* The general path: fallback(*args), or None without a fallback. */
static PyObject *general(Stepper *self, PyObject *const *args, size_t nargsf,
                         PyObject *kwnames) {
    if (self->fallback != NULL) return PyObject_Vectorcall(self->fallback, args, nargsf, kwnames);
    Py_RETURN_NONE;
}

static PyObject *stepper_call(PyObject *self_, PyObject *const *args, size_t nargsf,
                              PyObject *kwnames) {
    Stepper *self = (Stepper *)self_;
    Py_ssize_t nargs = PyVectorcall_NARGS(nargsf);
    if (nargs != 4 || (kwnames != NULL && PyTuple_GET_SIZE(kwnames) != 0)) {
        if (self->fallback != NULL) return general(self, args, nargsf, kwnames);
        PyErr_SetString(PyExc_TypeError, "Stepper takes 4 positional arguments");
        return NULL;
    }
    for (int i = 0; i < 4; i++) {
        if (!is_input(args[i])) return general(self, args, nargsf, kwnames);
    }
    PyArrayObject *S = self->state;
    if (!PyArray_ISWRITEABLE(S)) return general(self, args, nargsf, kwnames);
    PyObject *g = PyArray_SimpleNew(1, &self->n, NPY_DOUBLE);
    if (g == NULL) return NULL;
    int64_t code = self->kernel(DATA(S), (int64_t)PyArray_DIM(S, 0), (int64_t)PyArray_DIM(S, 1),
                                DATA(args[0]), LEN(args[0]), DATA(args[1]), LEN(args[1]),
                                DATA(args[2]), LEN(args[2]), DATA(args[3]), LEN(args[3]),
                                DATA(g), (int64_t)self->n);
    if (code != 0) {
        Py_DECREF(g);
        return general(self, args, nargsf, kwnames);
    }
    return g;
}

static PyObject *stepper_new(PyTypeObject *type, PyObject *args, PyObject *kwds) {
    PyObject *addr;
    PyObject *state;
    Py_ssize_t n;
    PyObject *fallback = Py_None;
    static char *kwlist[] = {"address", "state", "n", "fallback", NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O!On|O", kwlist, &PyLong_Type, &addr, &state,
                                     &n, &fallback))
        return NULL;
    if (fallback != Py_None && !PyCallable_Check(fallback)) {
        PyErr_SetString(PyExc_TypeError, "fallback must be callable or None");
        return NULL;
    }
    void *fn = PyLong_AsVoidPtr(addr);
    if (fn == NULL) {
        if (!PyErr_Occurred()) PyErr_SetString(PyExc_ValueError, "address must be non-zero");
        return NULL;
    }
    if (!(PyArray_Check(state) && PyArray_TYPE((PyArrayObject *)state) == NPY_DOUBLE
          && PyArray_NDIM((PyArrayObject *)state) == 2
          && PyArray_ISCARRAY((PyArrayObject *)state)
          && PyArray_DIM((PyArrayObject *)state, 0) == 1)) {
        PyErr_SetString(PyExc_TypeError,
                        "state must be a writeable C-contiguous float64 array of one row");
        return NULL;
    }
    if (n < 1) {
        PyErr_SetString(PyExc_ValueError, "n must be positive");
        return NULL;
    }
    Stepper *self = (Stepper *)type->tp_alloc(type, 0);
    if (self == NULL) return NULL;
    self->vectorcall = stepper_call;
    self->kernel = (step_kernel)fn;
    Py_INCREF(state);
    self->state = (PyArrayObject *)state;
    self->fallback = NULL;
    if (fallback != Py_None) {
        Py_INCREF(fallback);
        self->fallback = fallback;
    }
    self->n = (npy_intp)n;
    return (PyObject *)self;
}

/* Garbage-collector support: a fallback bound to the identifier that holds this Stepper
 * makes a reference cycle. */
static int stepper_traverse(Stepper *self, visitproc visit, void *arg) {
    Py_VISIT(self->state);
    Py_VISIT(self->fallback);
    return 0;
}

static int stepper_clear(Stepper *self) {
    Py_CLEAR(self->fallback); /* the state stays: a call after this still steps it */
    return 0;
}

static void stepper_dealloc(Stepper *self) {
    PyObject_GC_UnTrack(self);
    Py_CLEAR(self->fallback);
    Py_CLEAR(self->state);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static PyTypeObject StepperType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "simgap.identifiers._call.Stepper",
    .tp_doc = "Stepper(address, state, n, fallback=None)(x, u, f, x_next) -> g_hat, or "
              "fallback(x, u, f, x_next) (None without one) off the fast path",
    .tp_basicsize = sizeof(Stepper),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_VECTORCALL | Py_TPFLAGS_HAVE_GC,
    .tp_new = stepper_new,
    .tp_dealloc = (destructor)stepper_dealloc,
    .tp_traverse = (traverseproc)stepper_traverse,
    .tp_clear = (inquiry)stepper_clear,
    .tp_free = PyObject_GC_Del,
    .tp_vectorcall_offset = offsetof(Stepper, vectorcall),
    .tp_call = PyVectorcall_Call,
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_call",
    "C caller of the single-identifier step kernel (see _call.c).", -1, NULL,
};

PyMODINIT_FUNC PyInit__call(void) {
    import_array();
    if (PyType_Ready(&StepperType) < 0) return NULL;
    PyObject *m = PyModule_Create(&module);
    if (m == NULL) return NULL;
    Py_INCREF(&StepperType);
    if (PyModule_AddObject(m, "Stepper", (PyObject *)&StepperType) < 0) {
        Py_DECREF(&StepperType);
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
