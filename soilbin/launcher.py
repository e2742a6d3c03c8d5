"""The MPI launcher, for the commands that do not need MPI themselves (``point``,
``calibrate``): they start MPI only when ``mpirun`` started several ranks, so that a
serial run stays free to fork."""
import os


def mpi_world():
    """MPI.COMM_WORLD when an MPI launcher (Open MPI's or a PMI one) started more than one
    rank, else None."""
    size = os.environ.get("OMPI_COMM_WORLD_SIZE") or os.environ.get("PMI_SIZE")
    if size is None or int(size) < 2:
        return None
    from mpi4py import MPI
    return MPI.COMM_WORLD


def launched_rank():
    """This process's rank as the MPI launcher numbered it (0 without one), read before MPI
    starts."""
    return int(os.environ.get("OMPI_COMM_WORLD_RANK") or os.environ.get("PMI_RANK") or 0)
